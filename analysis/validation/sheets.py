#!/usr/bin/env python3
"""Contact sheets of the AU calibration renders: one JPEG per AU, the eight evaluation people in
rows and neutral, A, B, C, D, E in columns, the face cropped and downscaled.

    /tmp/validators-venv/bin/python analysis/validation/sheets.py \
        --renders /tmp/facslab-calibrate/table --out docs/au-sheets

Reads PERSON__EXPR.png as `calibrate.py table` writes them (485x480). Writes AU<code>.jpg
(quality 85, a few tens of KB each) and index.md listing them.
"""
import argparse
import os
import re

from PIL import Image, ImageDraw

from calibrate import EVALUATION_PEOPLE

CROP = (112, 60, 373, 400)  # the face in a 485x480 render (x0, y0, x1, y1)
TILE_W = 116
COLUMNS = ["0", "A", "B", "C", "D", "E"]
LABEL_H = 16


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--renders", default="/tmp/facslab-calibrate/table")
    ap.add_argument("--out", default="docs/au-sheets")
    ap.add_argument("--people", default=",".join(EVALUATION_PEOPLE))
    a = ap.parse_args()
    people = a.people.split(",")
    names = os.listdir(a.renders)
    codes = sorted({int(m.group(1)) for n in names if (m := re.match(r"[a-z0-9]+__(\d+)[A-D]?\.png$", n)) and m.group(1) != "0"})
    os.makedirs(a.out, exist_ok=True)
    tile_h = round(TILE_W * (CROP[3] - CROP[1]) / (CROP[2] - CROP[0]))
    index = ["# AU contact sheets", "", "Each sheet: the eight evaluation people (rows) at neutral and A–E (columns),",
             "rendered by `analysis/validation/calibrate.py table` and laid out by `sheets.py`;",
             "the measurements of the same renders are in `analysis/validation/results/calibration.csv`.",
             "`emfacs-prototypes.jpg`: the eight people's rows of `facslab sheet --set emotions` (every EmFACS prototype at E).", ""]
    for code in codes:
        sheet = Image.new("RGB", (TILE_W * len(COLUMNS) + 34, LABEL_H + tile_h * len(people)), "white")
        draw = ImageDraw.Draw(sheet)
        for j, col in enumerate(COLUMNS):
            draw.text((34 + j * TILE_W + TILE_W // 2 - 10, 2), f"{code}{col}" if col != "0" else "0", fill="black")
        for i, person in enumerate(people):
            draw.text((2, LABEL_H + i * tile_h + tile_h // 2 - 5), person, fill="black")
            for j, col in enumerate(COLUMNS):
                expr = "0" if col == "0" else (f"{code}" if col == "E" else f"{code}{col}")
                path = os.path.join(a.renders, f"{person}__{expr}.png")
                if not os.path.exists(path):
                    continue
                tile = Image.open(path).convert("RGB").crop(CROP).resize((TILE_W, tile_h), Image.LANCZOS)
                sheet.paste(tile, (34 + j * TILE_W, LABEL_H + i * tile_h))
        sheet.save(os.path.join(a.out, f"AU{code}.jpg"), quality=85, optimize=True)
        index.append(f"- [AU{code}](AU{code}.jpg)")
    with open(os.path.join(a.out, "index.md"), "w") as f:
        f.write("\n".join(index) + "\n")


if __name__ == "__main__":
    main()
