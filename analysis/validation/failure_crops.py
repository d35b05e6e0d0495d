#!/usr/bin/env python3
"""Pictures of the landmark checks that fail: for each failing row of `results/checks.csv`, the
neutral render and the AU render of that person side by side, cropped to the region the check
measures, with the MediaPipe Face Mesh landmarks the check reads drawn on both (red dots).

    /tmp/validators-venv/bin/python analysis/validation/failure_crops.py \
        --frames analysis/validation/results/frames --out docs/validation-failures

Reads the frames `landmarks.py` rendered (IDENTITY_EXPR.png, 485x480) and `results/checks.csv`.
Writes one PNG per failing check, AU<code>_<identity>_<measure>.png (neutral left, AU right,
320 px wide), and prints the file names with the landmark coordinates (pixels).
"""
import argparse
import csv
import os

import numpy as np
from PIL import Image, ImageDraw

from landmarks import BROW_IN, EYE, IRIS, LIDS, LIP_LO, LIP_UP, LIP_UP_OUT, NOSE_TIP

# The landmarks each measure reads, and those that frame its region.
BROW_LINE = [70, 63, 105, 66, 107, 336, 296, 334, 293, 300]
READS = {
    "brow_gap": [BROW_IN["R"], BROW_IN["L"]],
    "brow_inner": [BROW_IN["R"], BROW_IN["L"]],
    "lip_gap": [LIP_UP, LIP_LO],
    "upper_lip_to_nose": [NOSE_TIP, LIP_UP_OUT],
    "bs_eyeLookDown": [IRIS["R"], IRIS["L"]],
    "bs_eyeLookUp": [IRIS["R"], IRIS["L"]],
    "gaze_y": [IRIS["R"], IRIS["L"]] + EYE["R"] + EYE["L"],
    "eye_open": [i for side in "RL" for pair in LIDS[side][:3] for i in pair],
}
FRAME = {
    "brow_gap": BROW_LINE + EYE["R"] + EYE["L"],
    "brow_inner": BROW_LINE + EYE["R"] + EYE["L"],
    "lip_gap": [61, 291, 0, 17, 2],
    "upper_lip_to_nose": [61, 291, 17, 6, 48, 278],
    "bs_eyeLookDown": BROW_LINE + EYE["R"] + EYE["L"],
    "bs_eyeLookUp": BROW_LINE + EYE["R"] + EYE["L"],
    "gaze_y": BROW_LINE + EYE["R"] + EYE["L"],
    "eye_open": BROW_LINE + EYE["R"] + EYE["L"],
}
WIDTH = 320


def landmarks(mesh, path):
    rgb = np.asarray(Image.open(path).convert("RGB"))
    h, w = rgb.shape[:2]
    found = mesh.process(rgb).multi_face_landmarks
    return rgb, (np.array([(l.x * w, l.y * h) for l in found[0].landmark]) if found else None)


def measure_key(label):
    """The measure a checks.csv label is about ('brow_inner (mean L/R)', 'R1: brow_inner own/other side')."""
    for key in READS:
        if key in label:
            return key
    return None


def pair_picture(frames, identity, expression, key, mesh):
    pictures, marks = [], []
    for expr in ("0", expression):
        rgb, pts = landmarks(mesh, os.path.join(frames, f"{identity}_{expr}.png"))
        pictures.append(Image.fromarray(rgb))
        marks.append(pts)
    box_pts = np.vstack([p[FRAME[key]] for p in marks if p is not None])
    (x0, y0), (x1, y1) = box_pts.min(0) - 12, box_pts.max(0) + 12
    tiles = []
    for picture, pts in zip(pictures, marks):
        tile = picture.crop((int(x0), int(y0), int(x1), int(y1)))
        scale = (WIDTH // 2) / tile.width
        tile = tile.resize((WIDTH // 2, max(1, round(tile.height * scale))), Image.LANCZOS)
        draw = ImageDraw.Draw(tile)
        for i in READS[key]:
            x, y = (pts[i] - (x0, y0)) * scale
            draw.ellipse((x - 3, y - 3, x + 3, y + 3), fill=(255, 0, 0), outline=(255, 255, 255))
        tiles.append(tile)
    out = Image.new("RGB", (WIDTH + 2, tiles[0].height), "white")
    out.paste(tiles[0], (0, 0))
    out.paste(tiles[1], (WIDTH // 2 + 2, 0))
    return out, [None if p is None else p[READS[key]].round(1).tolist() for p in marks]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", default=os.path.join(here, "results", "frames"))
    ap.add_argument("--checks", default=os.path.join(here, "results", "checks.csv"))
    ap.add_argument("--out", default=os.path.join(here, "..", "..", "docs", "validation-failures"))
    a = ap.parse_args()
    import mediapipe as mp

    mesh = mp.solutions.face_mesh.FaceMesh(static_image_mode=True, max_num_faces=1, refine_landmarks=True,
                                           min_detection_confidence=0.5)
    os.makedirs(a.out, exist_ok=True)
    with open(a.checks) as f:
        failing = [r for r in csv.DictReader(f) if r["result"] == "FAIL"]
    for row in failing:
        key = measure_key(row["measure"])
        if key is None:
            print(f"no picture for {row}")
            continue
        side = row["measure"].split(":")[0] if ":" in row["measure"] else ""
        expression = side if side else row["au"]
        picture, marks = pair_picture(a.frames, row["identity"], expression, key, mesh)
        name = f"AU{row['au']}_{row['identity']}_{(side + '_') if side else ''}{key}.png"
        picture.save(os.path.join(a.out, name), optimize=True)
        print(name, "neutral", marks[0], "AU", marks[1])


if __name__ == "__main__":
    main()
