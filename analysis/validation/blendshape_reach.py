#!/usr/bin/env python3
"""How far a face would have to move for MediaPipe's blendshape model to reach an AU's floor.

MediaPipe FaceLandmarker scores its 52 blendshapes from landmarks alone: a small network (inside
`face_landmarker.task`, `face_blendshapes.tflite`) reads the x, y image positions of 146 of the
478 landmarks. So whether a blendshape can reach a floor is a question about landmark positions,
which this script answers directly, without rendering anything new:

  1. For each person and AU: render the neutral face and the AU at E (485x480), detect the
     landmarks and blendshapes with FaceLandmarker (as `raters.py --backends mp_tasks` does).
  2. Feed the AU's landmarks to the blendshape network and walk them, in steps of `--step`
     inter-ocular distances (IOD), along the steepest ascent of the blendshape's logit (numeric
     gradient over the 136 non-iris landmarks the network reads) until it reaches neutral + floor.
  3. Report how much further the landmarks had to move (Euclidean norm over all landmarks and
     the largest single landmark, in IOD) next to how far the AU itself moved them.

The steepest path is an estimate of the smallest move, not a proof; a large value says the
network wants a landmark configuration far from the one the AU produces. For scale: AU12 at E,
a broad smile, moves its largest landmark about 0.25 IOD (`results/calibration.csv`).

It also scores two real photographs that ship with the validators' Python packages (NASA's
portrait of Eileen Collins, smiling, from scikit-image; Grace Hopper from matplotlib), so the
blendshapes can be compared with what the network reads on real people.

    /tmp/validators-venv/bin/python analysis/validation/blendshape_reach.py \
        --facslab target/release/facslab --validators ../shared/tools/validators

Writes `results/blendshape_reach.csv` and `results/blendshape_reach.md`; renders go to --work.
"""
import argparse
import csv
import os
import sys
import zipfile

import numpy as np

from calibrate import BLENDSHAPES, EVALUATION_PEOPLE, detect, landmarker, render_all

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results")

# The 146 landmarks the blendshape network reads, in its input order (MediaPipe's
# face_blendshapes graph); the last ten are the irises, which this search leaves alone.
SUBSET = [
    0, 1, 4, 5, 6, 7, 8, 10, 13, 14, 17, 21, 33, 37, 39, 40, 46, 52, 53, 54, 55, 58, 61, 63, 65, 66,
    67, 70, 78, 80, 81, 82, 84, 87, 88, 91, 93, 95, 103, 105, 107, 109, 127, 132, 133, 136, 144, 145,
    146, 148, 149, 150, 152, 153, 154, 155, 157, 158, 159, 160, 161, 162, 163, 168, 172, 173, 176,
    178, 181, 185, 191, 195, 197, 234, 246, 249, 251, 263, 267, 269, 270, 276, 282, 283, 284, 285,
    288, 291, 293, 295, 296, 297, 300, 308, 310, 311, 312, 314, 317, 318, 321, 323, 324, 332, 334,
    336, 338, 356, 361, 362, 365, 373, 374, 375, 377, 378, 379, 380, 381, 382, 384, 385, 386, 387,
    388, 389, 390, 397, 398, 400, 402, 405, 409, 415, 454, 466, 468, 469, 470, 471, 472, 473, 474,
    475, 476, 477,
]
MOVABLE = SUBSET[:-10]


# AU -> its floor over neutral, as the floor check (`au_floors.py`) states them; the blendshapes
# are the calibration table's (`calibrate.BLENDSHAPES`).
FLOORS = {"6": 0.3, "9": 0.3, "14": 0.2, "5": 0.4, "2": 0.5, "24": 0.2, "17": 0.3, "28": 0.3}


class Network:
    """FaceLandmarker (landmarks + blendshapes from an image, as `calibrate.py` detects them) and
    its blendshape network alone."""

    def __init__(self, validators):
        from ai_edge_litert.interpreter import Interpreter
        self.tasks = landmarker(validators)
        import raters  # on the path once `calibrate.landmarker` has run
        with zipfile.ZipFile(raters.face_landmarker_task_path()) as z:
            model = z.read("face_blendshapes.tflite")
        self.net = Interpreter(model_content=model)
        self.net.allocate_tensors()
        self.inp = self.net.get_input_details()[0]["index"]
        self.out = self.net.get_output_details()[0]["index"]
        self.names = None

    def detect(self, path):
        pts, bs = detect(self.tasks, path)
        if bs is not None:
            self.names = list(bs)  # the network's output order
        return pts, bs

    def scores(self, pts):
        self.net.set_tensor(self.inp, pts[SUBSET][None].astype(np.float32))
        self.net.invoke()
        return self.net.get_tensor(self.out).copy()


def logit(p):
    p = np.clip(p, 1e-30, 1 - 1e-7)
    return np.log(p) - np.log1p(-p)


def steepest_path(net, pts, keys, target, step, max_steps):
    """Walks the landmarks up the mean logit of `keys` until their mean score reaches `target`."""
    idx = [net.names.index(k) for k in keys]
    value = lambda q: float(np.mean(net.scores(q)[idx]))
    objective = lambda q: float(np.mean(logit(net.scores(q)[idx])))
    q, steps = pts.copy(), 0
    while value(q) < target and steps < max_steps:
        base, grad = objective(q), np.zeros_like(q)
        for i in MOVABLE:
            for d in (0, 1):
                probe = q.copy()
                probe[i, d] += 0.5
                grad[i, d] = (objective(probe) - base) / 0.5
        q = q + step * grad / (np.linalg.norm(grad) + 1e-12)
        steps += 1
    return q, value(q), steps


def reach_rows(net, a):
    rows = []
    for person in a.people:
        path_of = lambda expr: os.path.join(a.work, f"{person}__{expr}.png")
        render_all(a.facslab, [(e, person, path_of(e)) for e in ["0", *a.aus]], a.workers)
        pts0, bs0 = net.detect(path_of("0"))
        iod = float(np.linalg.norm(pts0[468] - pts0[473]))  # iris centres
        for au in a.aus:
            keys, floor = BLENDSHAPES[int(au)], FLOORS[au]
            pts, bs = net.detect(path_of(au))
            v0, vE = np.mean([bs0[k] for k in keys]), np.mean([bs[k] for k in keys])
            q, reached, steps = steepest_path(net, pts, keys, v0 + floor, a.step * iod, a.max_steps)
            extra = np.linalg.norm(q - pts, axis=1) / iod
            own = np.linalg.norm(pts[:468] - pts0[:468], axis=1) / iod
            rows.append(dict(person=person, au=au, blendshape="+".join(keys), floor=floor,
                             neutral=f"{v0:.3f}", at_E=f"{vE:.3f}", over_neutral=f"{vE - v0:+.3f}",
                             reached=f"{reached:.3f}", steps=steps, au_max_iod=f"{own.max():.3f}",
                             extra_norm_iod=f"{np.linalg.norm(extra):.3f}", extra_max_iod=f"{extra.max():.3f}",
                             extra_max_landmark=int(extra.argmax())))
            print(rows[-1], flush=True)
    return rows


def photo_rows(net):
    import matplotlib
    import skimage
    from PIL import Image
    photos = {
        "astronaut (Eileen Collins, smiling; scikit-image)": os.path.join(os.path.dirname(skimage.__file__), "data", "astronaut.png"),
        "Grace Hopper (matplotlib sample data)": os.path.join(matplotlib.get_data_path(), "sample_data", "grace_hopper.jpg"),
    }
    rows = []
    for name, path in photos.items():
        tmp = os.path.join("/tmp", os.path.basename(path) + ".png")
        Image.open(path).convert("RGB").save(tmp)
        _, bs = net.detect(tmp)
        if bs:
            keys = [k for au in FLOORS for k in BLENDSHAPES[int(au)]] + BLENDSHAPES[12] + BLENDSHAPES[7]
            rows.append((name, {k: bs[k] for k in keys}))
    return rows


def write(rows, photos, results):
    os.makedirs(results, exist_ok=True)
    with open(os.path.join(results, "blendshape_reach.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = ["# How far the landmarks must move for a blendshape to reach its floor", "",
             "Written by `blendshape_reach.py`. Per person and AU at E: the blendshape over neutral, then the",
             "steepest path of the landmarks (fed straight to MediaPipe's blendshape network) to neutral +",
             "floor: the extra movement it needed (norm over all landmarks / largest single landmark, in",
             "inter-ocular distances) next to the largest move the AU itself makes. AU12 at E, a broad smile,",
             "moves its largest landmark about 0.25 IOD.", "",
             "| AU | blendshape (floor) | person | over neutral | AU's own largest move | extra norm | extra largest (landmark) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['au']} | {r['blendshape']} ({r['floor']}) | {r['person']} | {r['over_neutral']} | {r['au_max_iod']} | "
                     f"{r['extra_norm_iod']} | {r['extra_max_iod']} ({r['extra_max_landmark']}) |")
    lines += ["", "Real photographs, the same blendshapes:", "", "| photo | " + " | ".join(photos[0][1]) + " |",
              "|---|" + "---|" * len(photos[0][1])] if photos else []
    for name, bs in photos:
        lines.append(f"| {name} | " + " | ".join(f"{v:.3f}" for v in bs.values()) + " |")
    with open(os.path.join(results, "blendshape_reach.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--facslab", default="target/release/facslab")
    ap.add_argument("--validators", default=os.path.join(HERE, "..", "..", "..", "shared", "tools", "validators"))
    ap.add_argument("--work", default="/tmp/facslab-reach")
    ap.add_argument("--results", default=RESULTS)
    ap.add_argument("--people", type=lambda s: s.split(","), default=EVALUATION_PEOPLE)
    ap.add_argument("--aus", type=lambda s: s.split(","), default=["6", "9", "14", "5", "2"])
    ap.add_argument("--step", type=float, default=0.01, help="step along the gradient, in IOD")
    ap.add_argument("--max-steps", type=int, default=300)
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    unknown = [au for au in a.aus if au not in FLOORS]
    if unknown:
        ap.error(f"--aus: no floor for AU {', '.join(unknown)} (known: {', '.join(FLOORS)})")
    os.makedirs(a.work, exist_ok=True)
    net = Network(os.path.abspath(a.validators))
    photos = photo_rows(net)
    write(reach_rows(net, a), photos, a.results)


if __name__ == "__main__":
    main()
