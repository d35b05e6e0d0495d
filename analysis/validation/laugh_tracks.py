#!/usr/bin/env python3
"""MediaPipe landmark tracks of facslab's own laugh renders: the fixture `curves fit` is tested on.

Per take (`--source laugh`, the default): `facslab laugh laughter` performs a take (seeds 1 and 2,
wm1) and exports its timeline; with `--source timeline` the script writes a timeline itself (a
neutral start, AU6+AU12 rising to a held smile, three AU25+AU26 jaw pulses, release). The timeline
is rendered with `facslab render --timeline … --frames DIR` (the take's own frames: a timeline
reproduces its video exactly), MediaPipe FaceLandmarker (the validators' `mp_tasks` backend, 478
landmarks) runs on every frame, and the script writes

    tests/fixtures/laugh/mp_take{N}.csv     frame,x_0..x_477,y_0..y_477 (pixels, y down)
    tests/fixtures/laugh/mp_truth.csv       take,frame,au6,au12,au25,au26 (the rendered intensities)
    tests/fixtures/laugh/mp_au_poses.csv    expr,x_0..x_477,y_0..y_477: stills of neutral and single
                                            AUs at E on wm1 (the round-trip test's forward model)

    /tmp/validators-venv/bin/python analysis/validation/laugh_tracks.py \
        --facslab target/debug/facslab --validators ../shared/tools/validators

Frames where MediaPipe finds no face stop the script (the fixture must be complete).
"""
import argparse
import csv
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from calibrate import detect, landmarker  # noqa: E402

FPS = 15
# (identity, smile peak, jaw pulse peaks, pulse starts in s): two takes that differ in timing.
TAKES = [("wm1", 0.8, 0.7, [1.2, 1.8, 2.4]), ("wm1", 0.7, 0.6, [1.4, 2.1, 2.7])]
DURATION = 3.6


def keys(peak, pulses):
    """Per-AU key lists [(t, v)], linear between keys."""
    smile = [(0.0, 0.0), (0.5, 0.0), (1.0, peak), (3.0, peak), (3.4, 0.0), (DURATION, 0.0)]
    jaw = [(0.0, 0.0)]
    for s in pulses:
        jaw += [(s, 0.0), (s + 0.2, 1.0), (s + 0.4, 0.0)]
    jaw.append((DURATION, 0.0))
    return smile, jaw


def timeline(identity, size, peak, jaw_peak, pulses):
    smile, jaw = keys(peak, pulses)
    tracks = []
    for au, ks, scale in [(6, smile, 1.0), (12, smile, 1.0), (25, jaw, jaw_peak), (26, jaw, jaw_peak)]:
        for (t0, v0), (t1, v1) in zip(ks, ks[1:]):
            if t1 > t0 and (v0 or v1):
                tracks.append({"au": au, "side": "both", "start_intensity": v0 * scale, "end_intensity": v1 * scale,
                               "start_s": t0, "end_s": t1, "ramp": "linear"})
    return {"fps": FPS, "duration_s": DURATION, "identity": identity, "size": [size, size], "tracks": tracks}


def laugh_timeline(a, work, seed):
    """The timeline of a `facslab laugh laughter` take on wm1 at the fixture's size and rate."""
    path = os.path.join(work, "timeline.json")
    subprocess.run([a.facslab, "laugh", "laughter", "--identity", "wm1", "--size", f"{a.size}x{a.size}", "--fps", str(FPS),
                    "--seed", str(seed), "--export-timeline", path, "-o", os.path.join(work, "take.mp4")], check=True)
    return json.load(open(path))


def truth(tl, frames):
    rows = []
    for f in range(frames):
        t = f / tl["fps"]
        v = {au: 0.0 for au in (6, 12, 25, 26)}
        for tr in tl["tracks"]:
            if tr["start_s"] <= t <= tr["end_s"]:
                s = (t - tr["start_s"]) / (tr["end_s"] - tr["start_s"])
                v[tr["au"]] = tr["start_intensity"] + (tr["end_intensity"] - tr["start_intensity"]) * s
        rows.append(v)
    return rows


POSES = ["0", "1", "L1", "R1", "2", "4", "6", "L6", "R6", "9", "L9", "R9", "10", "12", "L12", "R12",
         "15", "L15", "R15", "25", "26", "43", "L43", "R43"]


def poses(a, lm):
    """One still per pose at E (a bare AU number is level E), landmarks in one CSV."""
    work = os.path.join(a.work, "poses")
    os.makedirs(work, exist_ok=True)
    with open(os.path.join(a.out, "mp_au_poses.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["expr"] + [f"x_{i}" for i in range(478)] + [f"y_{i}" for i in range(478)])
        for expr in POSES:
            png = os.path.join(work, f"{expr}.png")
            fac = expr if expr == "0" else expr + "E"
            subprocess.run([a.facslab, "render", fac, "--identity", "wm1", "--size", f"{a.size}x{a.size}", "-o", png], check=True)
            pts, _ = detect(lm, png)
            if pts is None:
                sys.exit(f"no face found in {png}")
            w.writerow([expr] + [f"{x:.2f}" for x in pts[:, 0]] + [f"{y:.2f}" for y in pts[:, 1]])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--facslab", required=True)
    ap.add_argument("--validators", required=True)
    ap.add_argument("--out", default=os.path.join(HERE, "..", "..", "tests", "fixtures", "laugh"))
    ap.add_argument("--work", default="/tmp/facslab-laugh-tracks")
    ap.add_argument("--size", type=int, default=320)
    ap.add_argument("--source", choices=["laugh", "timeline"], default="laugh")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    lm = landmarker(a.validators)
    truth_rows = []
    for n, (identity, peak, jaw_peak, pulses) in enumerate(TAKES, 1):
        work = os.path.join(a.work, f"take{n}")
        os.makedirs(os.path.join(work, "frames"), exist_ok=True)
        if a.source == "laugh":
            tl = laugh_timeline(a, work, n)
        else:
            tl = timeline(identity, a.size, peak, jaw_peak, pulses)
            json.dump(tl, open(os.path.join(work, "timeline.json"), "w"), indent=1)
        subprocess.run([a.facslab, "render", "--timeline", os.path.join(work, "timeline.json"), "-o",
                        os.path.join(work, "clip.mp4"), "--frames", os.path.join(work, "frames")], check=True)
        pngs = sorted(p for p in os.listdir(os.path.join(work, "frames")) if p.endswith(".png"))
        header = ["frame"] + [f"x_{i}" for i in range(478)] + [f"y_{i}" for i in range(478)]
        with open(os.path.join(a.out, f"mp_take{n}.csv"), "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(header)
            for i, png in enumerate(pngs):
                pts, _ = detect(lm, os.path.join(work, "frames", png))
                if pts is None:
                    sys.exit(f"take {n}: no face found in {png}")
                w.writerow([i] + [f"{x:.2f}" for x in pts[:, 0]] + [f"{y:.2f}" for y in pts[:, 1]])
        for f, v in enumerate(truth(tl, len(pngs))):
            truth_rows.append([n, f] + [f"{v[au]:.4f}" for au in (6, 12, 25, 26)])
        print(f"take {n}: {len(pngs)} frames")
    poses(a, lm)
    lm.close()
    with open(os.path.join(a.out, "mp_truth.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["take", "frame", "au6", "au12", "au25", "au26"])
        w.writerows(truth_rows)


if __name__ == "__main__":
    main()
