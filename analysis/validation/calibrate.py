#!/usr/bin/env python3
"""AU calibration of the face engine, measured with MediaPipe FaceLandmarker.

Two measurements: floors on every person `facslab identities` lists, the table on the eight
evaluation people (`EVALUATION_PEOPLE`; `--people` picks others):

  floors  renders PERSON__EXPR.png for the expressions the floor check lists (every AU at E that
          has a MediaPipe blendshape, the A..D ramps of AU4/12/26, the one-sided L/R AUs), runs
          `raters.py --backends mp_tasks` on them and then `au_floors.py`, and writes its output
          to `results/au_floors.txt`.
  table   renders every catalog AU at 0/A/B/C/D/E and writes `results/calibration.csv` (per AU,
          level and person: the largest and the mean landmark displacement from the person's
          neutral face in inter-ocular distances, and the MediaPipe blendshape value(s) that
          correspond to the AU, raw and over neutral) and `results/calibration.md` (the E rows).

    /tmp/validators-venv/bin/python analysis/validation/calibrate.py floors \
        --facslab target/release/facslab --validators ../shared/tools/validators
    /tmp/validators-venv/bin/python analysis/validation/calibrate.py table --facslab ...

Renders go to --work (default /tmp/facslab-calibrate), never into the repository; a rerun with
the same binary reuses them, one with another build starts afresh (`renders.py`). Sides: "L"/"R"
are the person's own left/right; MediaPipe's fooLeft/fooRight blendshapes are also the person's own.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from PIL import Image

from renders import renders_of

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results")
SIZE = "485x480"
LEVELS = ["A", "B", "C", "D", ""]  # "" = E (no suffix)

FLOOR_EXPRESSIONS = (
    "0 1 2 4 5 6 7 9 10 12 14 15 17 18 20 22 24 26 27 28 43".split()
    + [au + s for au in ("12", "4", "26") for s in "ABCD"]
    + [p + au for au in ("12", "2", "10", "20") for p in "LR"]
)


def side(k):
    return [k + "Left", k + "Right"]


# The MediaPipe blendshape(s) that correspond to an AU (mean of the list); AUs without one get
# only the landmark displacement.
BLENDSHAPES = {
    1: ["browInnerUp"], 2: side("browOuterUp"), 4: side("browDown"), 5: side("eyeWide"),
    6: side("cheekSquint"), 7: side("eyeSquint"), 9: side("noseSneer"), 10: side("mouthUpperUp"),
    11: side("mouthUpperUp"), 12: side("mouthSmile"), 13: side("mouthSmile"), 14: side("mouthDimple"),
    15: side("mouthFrown"), 16: side("mouthLowerDown"), 17: ["mouthShrugLower"], 18: ["mouthPucker"],
    20: side("mouthStretch"), 22: ["mouthFunnel"], 23: side("mouthPress"), 24: side("mouthPress"),
    25: side("mouthLowerDown"), 26: ["jawOpen"], 27: ["jawOpen"], 28: ["mouthRollLower", "mouthRollUpper"],
    29: ["jawForward"], 30: ["jawLeft"], 33: ["cheekPuff"], 34: ["cheekPuff"], 41: side("eyeBlink"),
    42: side("eyeBlink"), 43: side("eyeBlink"), 44: side("eyeSquint"), 45: side("eyeBlink"),
    46: side("eyeBlink"), 61: side("eyeLookOut")[:1] + side("eyeLookIn")[1:],
    62: side("eyeLookIn")[:1] + side("eyeLookOut")[1:], 63: side("eyeLookUp"), 64: side("eyeLookDown"),
}
EYE_R, EYE_L = [33, 133, 159, 145], [362, 263, 386, 374]
# The eight evaluation people (HapFACS's evaluation identities, `facslab identities` lists them first).
EVALUATION_PEOPLE = "wm1 wm2 bm1 bm2 wf1 wf2 bf1 bf2".split()


def identities(facslab):
    out = subprocess.run([facslab, "identities"], check=True, capture_output=True, text=True).stdout
    ids = [line.split()[0] for line in out.splitlines() if line.strip() and not line.startswith(("id", "ID", "#", "-"))]
    return [i for i in ids if i.replace("_", "").isalnum()]


def catalog_codes(repo):
    import tomllib
    with open(os.path.join(repo, "stimuli", "facs", "action_units.toml"), "rb") as f:
        return [u["code"] for u in tomllib.load(f)["action_unit"]]


def render_all(facslab, jobs, workers):
    """jobs: (expression, identity, path); renders the ones not yet on disk (see `renders_of`)."""
    def one(job):
        expr, ident, path = job
        if not os.path.exists(path):
            subprocess.run([facslab, "render", expr, "--identity", ident, "-o", path, "--size", SIZE, "--threads", "1"],
                           check=True, capture_output=True)
    with ThreadPoolExecutor(workers) as pool:
        list(pool.map(one, jobs))


def floors(a):
    work = renders_of(a.facslab, os.path.join(a.work, "floors"))
    people = a.people or identities(a.facslab)
    render_all(a.facslab, [(e, p, os.path.join(work, f"{p}__{e}.png")) for p in people for e in FLOOR_EXPRESSIONS], a.workers)
    rows = os.path.join(a.work, "floors.jsonl")
    subprocess.run([sys.executable, os.path.join(a.validators, "raters.py"), work, "--json", rows, "--backends", "mp_tasks"],
                   check=True, capture_output=True)
    res = subprocess.run([sys.executable, os.path.join(a.validators, "au_floors.py"), rows], capture_output=True, text=True)
    os.makedirs(a.results, exist_ok=True)
    with open(os.path.join(a.results, "au_floors.txt"), "w") as f:
        f.write(res.stdout)
    print(res.stdout)
    return res.returncode


def landmarker(validators):
    sys.path.insert(0, validators)
    import raters  # noqa: E402  (the validators' own MediaPipe wrapper)
    return raters.MpTasks()


def detect(lm, path):
    rgb = np.asarray(Image.open(path).convert("RGB"))
    h, w = rgb.shape[:2]
    r = lm.lm.detect(lm.mp.Image(image_format=lm.mp.ImageFormat.SRGB, data=np.ascontiguousarray(rgb)))
    if not r.face_landmarks:
        return None, None
    pts = np.array([(p.x * w, p.y * h) for p in r.face_landmarks[0]])
    return pts, {c.category_name: float(c.score) for c in r.face_blendshapes[0]}


def table(a):
    work = renders_of(a.facslab, os.path.join(a.work, "table"))
    people = a.people or EVALUATION_PEOPLE
    codes = catalog_codes(os.path.dirname(os.path.dirname(HERE)))
    exprs = ["0"] + [f"{c}{lv}" for c in codes for lv in LEVELS]
    render_all(a.facslab, [(e, p, os.path.join(work, f"{p}__{e}.png")) for p in people for e in exprs], a.workers)
    lm = landmarker(a.validators)
    rows = []
    for p in people:
        pts0, bs0 = detect(lm, os.path.join(work, f"{p}__0.png"))
        iod = np.linalg.norm(pts0[EYE_L].mean(0) - pts0[EYE_R].mean(0))
        for c in codes:
            keys = BLENDSHAPES.get(c, [])
            for lv in ["0"] + LEVELS:
                expr = "0" if lv == "0" else f"{c}{lv}"
                pts, bs = (pts0, bs0) if lv == "0" else detect(lm, os.path.join(work, f"{p}__{expr}.png"))
                row = {"au": c, "level": lv or "E", "person": p, "found": pts is not None}
                if pts is not None:
                    d = np.linalg.norm(pts[:468] - pts0[:468], axis=1) / iod
                    row.update(disp_max_iod=f"{d.max():.4f}", disp_mean_iod=f"{d.mean():.4f}")
                    if keys:
                        v, v0 = np.mean([bs[k] for k in keys]), np.mean([bs0[k] for k in keys])
                        row.update(blendshape="+".join(keys), value=f"{v:.3f}", over_neutral=f"{v - v0:+.3f}")
                rows.append(row)
    lm.close()
    os.makedirs(a.results, exist_ok=True)
    fields = ["au", "level", "person", "found", "disp_max_iod", "disp_mean_iod", "blendshape", "value", "over_neutral"]
    with open(os.path.join(a.results, "calibration.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fields)
        w.writeheader()
        w.writerows(rows)
    write_summary(rows, people, codes, os.path.join(a.results, "calibration.md"))
    return 0


def write_summary(rows, people, codes, path):
    by = {(r["au"], r["level"], r["person"]): r for r in rows}
    lines = ["# AU calibration (MediaPipe FaceLandmarker on the eight evaluation people)", "",
             "Each cell: largest landmark displacement from neutral in inter-ocular distances, and in",
             "brackets the AU's blendshape over neutral (A / C / E). Full table: `calibration.csv`.", "",
             "| AU | blendshape | " + " | ".join(people) + " |", "|---|---|" + "---|" * len(people)]
    for c in codes:
        keys = BLENDSHAPES.get(c)
        cells = []
        for p in people:
            parts = []
            for lv in "ACE":
                r = by.get((c, lv, p), {})
                if not r.get("found"):
                    parts.append("n/f")
                    continue
                parts.append(r["disp_max_iod"] + (f" ({r['over_neutral']})" if keys else ""))
            cells.append(" / ".join(parts))
        lines.append(f"| {c} | {'+'.join(keys) if keys else '-'} | " + " | ".join(cells) + " |")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mode", choices=["floors", "table"])
    ap.add_argument("--facslab", default="target/release/facslab")
    ap.add_argument("--validators", default=os.path.join(HERE, "..", "..", "..", "shared", "tools", "validators"))
    ap.add_argument("--work", default="/tmp/facslab-calibrate")
    ap.add_argument("--results", default=RESULTS)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--people", type=lambda s: s.split(","), default=None,
                    help="comma-separated ids (default: floors on everyone, the table on the eight evaluation people)")
    a = ap.parse_args()
    a.validators = os.path.abspath(a.validators)
    sys.exit(floors(a) if a.mode == "floors" else table(a))


if __name__ == "__main__":
    main()
