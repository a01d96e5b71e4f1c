"""A prior on the camera's roll and tilt in the choice among refined poses (a probe on stored rows, 2026-12-05).

``python experiments/ch1/orientation-prior/probe.py [ROWS.json]``   (default: the shipped confidence's rows)

Hand-held photos stand nearly upright, and most look near the horizon; the refined look-alikes that beat
the right place often need several degrees of roll or a steep tilt. Each row's refined poses (x, y, z, pan,
tilt, swing, f, score) are re-scored as score + a |swing| + b max(0, |tilt| - 15 deg) (px), the answer taken
as the best re-scored pose, and the photo confidence refitted on the re-scored rows
(``localize_fit.fit_confidence``, runner-up beyond 1 km): how many answers lie within 1 km, how many of
them the fit keeps above its threshold, and the leave-place-out count (right / wrong answered).
"""

from __future__ import annotations

import copy
import json
import os
import sys

import numpy as np

from skyrender.datasets.real_photos import REPO
from skyrender.training.localize_fit import fit_confidence

ROWS = os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")


def rescored(rows: list[dict], a: float, b: float) -> list[dict]:
    out = []
    for r in rows:
        r = copy.deepcopy(r)
        poses = np.asarray(r.get("refined_poses") or [], np.float64).reshape(-1, 8)
        if len(poses):
            poses[:, 7] += a * np.abs(poses[:, 5]) + b * np.maximum(0.0, np.abs(poses[:, 4]) - 15.0)
            best = int(np.argmin(poses[:, 7]))
            r["refined_poses"] = poses.tolist()
            r["error_m"] = float(np.hypot(*(poses[best, :2] - np.asarray(r["truth_xy"]))))
            r["best_score"] = float(poses[best, 7])
        out.append(r)
    return out


def main(path: str = ROWS) -> None:
    rows = json.load(open(path))["rows"]
    print(f"{len(rows)} rows of {os.path.relpath(path, REPO)}")
    print(f"{'a px/deg roll':>14s} {'b px/deg tilt':>14s} {'within 1 km':>12s} {'kept':>5s} {'threshold':>9s} "
          f"{'LPO right/wrong':>16s}")
    for a in (0.0, 0.025, 0.05, 0.1, 0.2):
        for b in (0.0, 0.05, 0.1):
            fit = fit_confidence(rescored(rows, a, b), (1000.0,))
            loo = fit["leave_place_out"]["margin"]
            print(f"{a:14.3f} {b:14.3f} {fit['right']:12d} {fit['kept_by_runner_up_m']['1000']:5d} "
                  f"{fit['min_confidence']:9.2f} {loo['right']:7d} / {loo['wrong']:<7d}")


if __name__ == "__main__":
    main(*sys.argv[1:2])
