#!/usr/bin/env python3
"""Plot the AU curves `facslab curves fit` found on the MediaPipe fixture against the rendered ones.

    facslab curves fit tests/fixtures/laugh/mp_take1.csv tests/fixtures/laugh/mp_take2.csv \
        --type laughter --fps 15 -o /tmp/mp.json
    /tmp/validators-venv/bin/python analysis/validation/laugh_fit_plot.py /tmp/mp.json \
        -o docs/laugh-curves/mediapipe_fit.png
"""
import argparse
import csv
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
TRUTH = os.path.join(HERE, "..", "..", "tests", "fixtures", "laugh", "mp_truth.csv")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("curves")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args()
    c = json.load(open(a.curves))
    take = c["fit"]["prototype"] + 1
    truth = [r for r in csv.DictReader(open(TRUTH)) if int(r["take"]) == take]
    fitted = {(t["au"], t.get("side", "both")): t["values"] for t in c["tracks"]}
    t = [i / c["fps"] for i in range(len(truth))]
    fig, axes = plt.subplots(2, 1, figsize=(7, 4.5), sharex=True)
    for ax, au in zip(axes, [12, 26]):
        ax.plot(t, [float(r[f"au{au}"]) for r in truth], "k--", label=f"AU{au} rendered")
        ax.plot(t, fitted[(au, "both")], "C1", label=f"AU{au} fitted from MediaPipe landmarks")
        ax.set_ylim(-0.05, 1.05)
        ax.set_ylabel("intensity")
        ax.legend(loc="upper left", fontsize=8)
    axes[1].set_xlabel("time (s)")
    eps, dist = c["fit"]["epsilon"], c["fit"]["distance"]
    fig.suptitle(f"curves fit on {os.path.basename(c['source'])} (ε {eps}, DTW {dist})", fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(a.output) or ".", exist_ok=True)
    fig.savefig(a.output, dpi=100)


if __name__ == "__main__":
    main()
