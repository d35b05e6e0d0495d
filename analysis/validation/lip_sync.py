#!/usr/bin/env python3
"""Lip-sync check of a speaking face with MediaPipe: does the lip gap follow the phones and the sound?

Makes a speaking video with `facslab speak` (its WAV and per-frame ground truth beside it), finds
the 478 MediaPipe Face Mesh landmarks and the 52 blendshapes in every frame, and measures the lip
gap (inner upper to inner lower lip, landmarks 13 and 14, in inter-ocular distances, via
landmarks.measures) and MediaPipe's `jawOpen`. Reports their mean per viseme class (open vowels
against p/b/m), their correlation with the sound's loudness (RMS over each frame's 1/30 s,
centred on the frame), and the lag of the best correlation (parabolic peak within ±5 frames;
positive = the mouth moves after the sound).

    /tmp/validators-venv/bin/python analysis/validation/lip_sync.py --facslab target/debug/facslab \
        --validators ../shared/tools/validators --out analysis/validation/results

Writes `results/lip_sync.csv` (one row per frame) and `results/lip_sync.md` (the summary quoted
in docs/speech.md).
"""
import argparse
import csv
import os
import subprocess
import sys
import wave

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from calibrate import detect, landmarker  # noqa: E402
from landmarks import measures  # noqa: E402

SENTENCE = "Bob and Pam bought a mop, a map and a pot of papaya."


def make_video(facslab, work, size):
    mp4 = os.path.join(work, "lip.mp4")
    subprocess.run([facslab, "speak", SENTENCE, "--identity", "wm1", "--size", f"{size}x{size}", "-o", mp4, "--wav", "--ground-truth"], check=True)
    frames = os.path.join(work, "frames")
    os.makedirs(frames, exist_ok=True)
    subprocess.run(["ffmpeg", "-v", "error", "-y", "-i", mp4, os.path.join(frames, "%06d.png")], check=True)
    return mp4


def loudness(wav_path, fps, n):
    with wave.open(wav_path) as w:
        rate = w.getframerate()
        x = np.frombuffer(w.readframes(w.getnframes()), dtype="<i2").astype(float) / 32768.0
    out = []
    for f in range(n):
        a, b = max(0, int((2 * f - 1) * rate / (2 * fps))), int((2 * f + 1) * rate / (2 * fps))
        seg = x[a:min(b, len(x))]
        out.append(float(np.sqrt(np.mean(seg ** 2))) if len(seg) else 0.0)
    return np.array(out)


def best_lag(mouth, loud):
    def r(lag):
        a, b = (loud[: len(loud) - lag], mouth[lag:]) if lag >= 0 else (loud[-lag:], mouth[: len(mouth) + lag])
        return float(np.corrcoef(a, b)[0, 1])
    rs = [r(lag) for lag in range(-5, 6)]
    k = int(np.argmax(rs))
    if 0 < k < len(rs) - 1:
        lo, c, hi = rs[k - 1], rs[k], rs[k + 1]
        return k - 5 + 0.5 * (lo - hi) / (lo - 2 * c + hi), rs[k], rs[5]
    return k - 5.0, rs[k], rs[5]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--facslab", required=True)
    ap.add_argument("--validators", required=True)
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    ap.add_argument("--work", default="/tmp/facslab-lip-sync")
    ap.add_argument("--size", type=int, default=320)
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    mp4 = make_video(a.facslab, a.work, a.size)
    truth = list(csv.DictReader(open(mp4[:-4] + ".csv")))
    lm = landmarker(a.validators)
    rows = []
    for i, t in enumerate(truth):
        pts, bs = detect(lm, os.path.join(a.work, "frames", f"{i + 1:06d}.png"))
        if pts is None:
            sys.exit(f"no face found in frame {i}")
        rows.append({"frame": i, "phoneme": t["phoneme"], "viseme": t["viseme"], "lip_gap": measures(pts)["lip_gap"], "jaw_open": bs["jawOpen"]})
    lm.close()
    loud = loudness(mp4[:-4] + ".wav", 30, len(rows))
    for r, v in zip(rows, loud):
        r["rms"] = v
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "lip_sync.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [f"# Lip sync on MediaPipe landmarks\n\n\"{SENTENCE}\", wm1, {a.size} x {a.size}, 30 fps, {len(rows)} frames.\n",
             "| measure | rest | open vowels | p/b/m | r with loudness (same frame) | best lag (frames) | r at best lag |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for key in ["lip_gap", "jaw_open"]:
        x = np.array([r[key] for r in rows])
        mean = lambda cls: float(np.mean([r[key] for r in rows if r["viseme"] == cls]))  # noqa: E731
        lag, r_best, r0 = best_lag(x, loud)
        lines.append(f"| {key} | {mean('rest'):.4f} | {mean('open'):.4f} | {mean('bilabial'):.4f} | {r0:.3f} | {lag:+.2f} | {r_best:.3f} |")
    text = "\n".join(lines) + "\n"
    open(os.path.join(a.out, "lip_sync.md"), "w").write(text)
    print(text)


if __name__ == "__main__":
    main()
