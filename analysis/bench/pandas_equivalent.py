#!/usr/bin/env python3
"""The rater part of `facslab analyze`, written the usual way with pandas + pingouin + scipy.

Used only as a timing baseline for `benches/analyze.rs` (see RESULTS.md): it reads the same
long-format response file and manifest and computes the same report content for an Exp. 3 study:
per media x intensity condition the confusion matrix (counts and row percent), recognition rates,
unbiased hit rates (Hu, Wagner 1993), exact binomial tests against chance, believability
mean/SD and Cronbach's alpha (participants = items, stimuli = cases, complete cases) per
condition and per condition x emotion; Student and Welch t-tests between participant groups on
per-participant recognition and mean believability; and per media the emotion x intensity
two-way ANOVA (Type II and III) on recognition and on believability. Writes report.json and one
CSV per confusion matrix.

    python3 pandas_equivalent.py responses.csv manifest.csv OUTDIR
"""

import json
import os
import sys
import time

import numpy as np
import pandas as pd
import pingouin as pg
from scipy import stats


def main(responses_path, manifest_path, out):
    t0 = time.perf_counter()
    r = pd.read_csv(responses_path, dtype={"participant_id": str, "group": str, "stimulus_id": str, "value": str})
    m = pd.read_csv(manifest_path, dtype={"stimulus_id": str})
    # Validation the Rust reader also does (ids known, Likert range, one judgement per cell).
    judged = r[r["stimulus_id"].notna()]
    unknown = ~judged["stimulus_id"].isin(m["stimulus_id"])
    if unknown.any():
        raise SystemExit(f"unknown stimulus id on row {unknown.idxmax() + 1}")
    if judged.duplicated(["participant_id", "stimulus_id", "measure"]).any():
        raise SystemExit("duplicate judgement")
    m["intensity_percent"] = (m["intensity"] * 100).round().astype(int)
    m["condition"] = m["media"] + " " + m["intensity_percent"].astype(str) + "%"
    d = judged.merge(m[["stimulus_id", "media", "intensity_percent", "condition", "emotion"]], on="stimulus_id")

    labels = sorted(l for l in set(m["emotion"].dropna()) | {"contempt", "embarrassment", "pride"} if l != "neutral")
    labels = labels + ["neutral", "none"]
    chance = 1 / len(labels)
    emo = d[d["measure"] == "emotion"].copy()
    emo["correct"] = (emo["value"] == emo["emotion"]).astype(float)
    bel = d[d["measure"] == "believability"].copy()
    bel["rating"] = bel["value"].astype(int)
    if not bel["rating"].between(1, 5).all():
        raise SystemExit("believability out of range")

    report = {"labels": labels, "chance": chance, "conditions": [], "group_tests": [], "anova": []}
    os.makedirs(out, exist_ok=True)
    groups = sorted(r["group"].unique())
    for cond, e in emo.groupby("condition", sort=False):
        counts = pd.crosstab(e["emotion"], e["value"]).reindex(columns=labels, fill_value=0)
        percent = counts.div(counts.sum(axis=1), axis=0) * 100
        counts.to_csv(os.path.join(out, f"confusion_{cond.replace(' ', '_').replace('%', '')}.csv"))
        full = counts.reindex(index=labels, fill_value=0)
        col = full.sum(axis=0)
        rows = []
        for shown, row in counts.iterrows():
            n, hits = int(row.sum()), int(row[shown])
            b = stats.binomtest(hits, n, chance, alternative="greater")
            ci = b.proportion_ci(0.95, method="exact")
            hu = hits**2 / (n * col[shown]) if col[shown] else 0.0
            hu_chance = (n / full.values.sum()) * (col[shown] / full.values.sum())
            rows.append({"emotion": shown, "answers": n, "hits": hits, "rate": hits / n, "hu": hu, "hu_chance": hu_chance,
                         "binomial_p": b.pvalue, "rate_ci95": [ci.low, ci.high]})
        c = {"key": cond, "confusion": counts.values.tolist(), "percent": percent.values.tolist(), "emotions": rows,
             "average_rate": float(np.mean([x["rate"] for x in rows])), "accuracy": float(e["correct"].mean())}
        # Believability: mean, SD, alpha per condition and per condition x emotion.
        b = bel[bel["condition"] == cond]
        def alpha(sub):
            wide = sub.pivot(index="stimulus_id", columns="participant_id", values="rating").dropna(axis=1)
            if wide.shape[0] < 2 or wide.shape[1] < 2:
                return None
            return float(pg.cronbach_alpha(data=wide)[0])
        cells = []
        for label, sub in b.groupby("emotion"):
            cells.append({"emotion": label, "n": len(sub), "mean": sub["rating"].mean(), "sd": sub["rating"].std(ddof=1), "alpha": alpha(sub)})
        c["believability"] = {"n": len(b), "mean": b["rating"].mean(), "sd": b["rating"].std(ddof=1), "alpha": alpha(b), "cells": cells}
        report["conditions"].append(c)
        # Group comparisons on per-participant recognition and mean believability.
        per_p = e.groupby(["participant_id", "group"])["correct"].mean().reset_index()
        per_pb = b.groupby(["participant_id", "group"])["rating"].mean().reset_index()
        per_pe = e.groupby(["participant_id", "group", "emotion"])["correct"].mean().reset_index()
        for i, ga in enumerate(groups):
            for gb in groups[i + 1:]:
                def tt(x, y, what, emotion="all"):
                    if len(x) == 0 or len(y) == 0:
                        return
                    student = pg.ttest(x, y, correction=False, confidence=0.95)
                    welch = pg.ttest(x, y, correction=True, confidence=0.95)
                    report["group_tests"].append({"condition": cond, "emotion": emotion, "outcome": what, "a": ga, "b": gb,
                                                  "student": student.iloc[0].to_dict(), "welch": welch.iloc[0].to_dict()})
                tt(per_p.loc[per_p["group"] == ga, "correct"], per_p.loc[per_p["group"] == gb, "correct"], "recognition")
                tt(per_pb.loc[per_pb["group"] == ga, "rating"], per_pb.loc[per_pb["group"] == gb, "rating"], "believability")
                for label, pe in per_pe.groupby("emotion"):
                    tt(pe.loc[pe["group"] == ga, "correct"], pe.loc[pe["group"] == gb, "correct"], "recognition", label)
    for media in ["video", "image"]:
        for outcome, frame, dv in [("recognition", emo, "correct"), ("believability", bel, "rating")]:
            sub = frame[frame["media"] == media].assign(intensity=lambda f: f["intensity_percent"].astype(str) + "%")
            for ss_type in (2, 3):
                table = pg.anova(data=sub, dv=dv, between=["emotion", "intensity"], ss_type=ss_type, detailed=True)
                report["anova"].append({"media": media, "outcome": outcome, "ss_type": ss_type, "table": table.to_dict(orient="records")})
    with open(os.path.join(out, "report.json"), "w") as f:
        json.dump(report, f, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))
    print(f"analysed {len(r)} rows in {time.perf_counter() - t0:.2f} s", file=sys.stderr)


if __name__ == "__main__":
    main(*sys.argv[1:4])
