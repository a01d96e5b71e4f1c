"""Offline: the photo confidence when the answer and its runner-up are taken among refined poses on
ground a person stands on (slope <= S). Reads the shipped training rows and terrain_stats.py's output.

    python experiments/ch1/standable/confidence_probe.py experiments/ch1/confidence-train-rows.json STATS.json
"""
import json
import sys

import numpy as np

from skyrender.training.localize_fit import fit_at, leave_place_out

rows = json.load(open(sys.argv[1]))["rows"]
stats = {o["photo"]: o for o in json.load(open(sys.argv[2]))}
places = np.array([stats[r["photo"]]["place"] for r in rows])


def pick(row, max_slope):
    """(answer index, runner-up index or None) among refined poses with slope <= max_slope (all when none is)."""
    P = np.asarray(row["refined_poses"], float)
    slope = np.array([p[0] for p in stats[row["photo"]]["poses"]])
    ok = ~(slope > max_slope)  # NaN (off the DEM) counts as standable, as in the pipeline
    if not ok.any():
        ok[:] = True
    idx = np.flatnonzero(ok)
    best = idx[np.argmin(P[idx, 7])]
    far = idx[np.hypot(P[idx, 0] - P[best, 0], P[idx, 1] - P[best, 1]) > 1000.0]
    return P, best, (far[np.argmin(P[far, 7])] if len(far) else None)


print(f"{'slope bound':>12} | right (of {len(rows)}) | right above threshold | threshold | leave place out right / wrong")
for S in (np.inf, 40.0, 35.0, 30.0, 25.0):
    margin, log_best, right = [], [], []
    for r in rows:
        P, b, i = pick(r, S)
        margin.append(1.0 - P[b, 7] / P[i, 7] if i is not None else 1.0)
        log_best.append(np.log(P[b, 7]))
        right.append(np.hypot(P[b, 0] - r["truth_xy"][0], P[b, 1] - r["truth_xy"][1]) <= 1000.0)
    margin, log_best, right = np.array(margin), np.array(log_best), np.array(right)
    fit = fit_at(margin, log_best, right)
    above = int(np.sum((fit["confidence"] >= fit["threshold"]) & right))
    loo = leave_place_out(margin, log_best, right, places, score_term=False)
    print(f"{S:12.0f} | {right.sum():13d} | {above:21d} | {fit['threshold']:9.2f} | {loo['right']} / {loo['wrong']}")
