"""Focal-length seeds at the fov-unknown answers (a probe on stored rows, 2026-12-05; nothing shipped).

``python experiments/ch1/focal-seeds/probe.py polish OUT.json ROWS.json [ROWS.json ...]``
    Each of the best 3 places (more than 1 km apart) among a row's stored refined poses is refined again
    (``refine_pose``, focal length free) from its own focal length divided by 0.85, 1 and 1.15, and keeps the best
    of those where it scores better; the answer, the margin to the runner-up and the confidence (the shipped logit)
    are then taken as the localizer takes them.
``python experiments/ch1/focal-seeds/probe.py spread OUT.json ROWS.json [ROWS.json ...]``
    At each row's answer only, the same three refinements; the spread is the largest distance between the three
    refined positions (m): how ill-determined the position is along the view with the fov unknown.

ROWS: ``real_localize --fov unknown --no-abstain`` runs of the training side (``../fov-unknown-fast/``,
``../fov-unknown-range/``).
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, refined_of, with_terrain
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer.confidence import distinct_places, margin_logistic, runner_up_index
from skyrender.localizer.refinement import refine_pose

SEEDS = (0.85, 1.0, 1.15)  # the fov times about these


def seeded(terrain, pose: np.ndarray, shape, sky, weights, params) -> list:
    """Refinements of one stored pose (x, y, z, pan, tilt, swing, f_px, score) from each focal seed."""
    H, W = shape
    out = []
    for s in SEEDS:
        f_px = pose[6] / s
        out.append(refine_pose(terrain, pose[:6], Intrinsics(W, H, f_px, W / 2, H / 2), 2.0, sky, weights,
                               fit_focal=True, f_px=f_px, params=params.score, refine=params.refine))
    return out


def answer(poses: np.ndarray, truth: np.ndarray, logit: tuple, W: int) -> dict:
    """The answer among refined poses as the localizer takes it: error (m), margin, confidence, fov (deg)."""
    best = int(np.argmin(poses[:, 7]))
    i = runner_up_index(poses[:, :2], poses[:, 7], best, 1000.0)
    margin = 1.0 - poses[best, 7] / poses[i, 7] if i is not None else 1.0
    return {"error_m": float(np.hypot(*(poses[best, :2] - truth))), "margin": float(margin),
            "confidence": float(margin_logistic(margin, logit[:2])),
            "fov": float(2 * np.degrees(np.arctan(W / 2 / poses[best, 6])))}


def main(mode: str, out: str, files: list[str]) -> None:
    params = LocalizeParams.for_photos()
    items = {it.key: it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")}
    rows = [r for f in files for r in json.load(open(f))["photos"] if r["photo"] in items]
    result = []
    for row, it, terrain in with_terrain(rows, items):
        t0 = time.perf_counter()
        image, sky, weights = photo_skyline(it, params)
        H, W = image.shape[:2]
        truth = np.asarray(row["truth_xy"])
        poses = refined_of(row).copy()
        before = answer(poses, truth, params.margin_logit, W)
        record = {"photo": it.key, "before": before}
        if mode == "polish":
            for i in distinct_places(poses, 3):
                best = min(seeded(terrain, poses[i], (H, W), sky, weights, params), key=lambda r: r.score)
                if best.score < poses[i, 7]:
                    poses[i] = np.r_[best.pose, best.f_px, best.score]
            record["after"] = answer(poses, truth, params.margin_logit, W)
            line = (f"err {before['error_m']:7.0f} -> {record['after']['error_m']:7.0f} m  conf {before['confidence']:.3f}"
                    f" -> {record['after']['confidence']:.3f}  fov {before['fov']:5.1f} -> {record['after']['fov']:5.1f}")
        else:
            b = int(np.argmin(poses[:, 7]))
            runs = seeded(terrain, poses[b], (H, W), sky, weights, params)
            xy = np.array([r.pose[:2] for r in runs])
            record["seeds"] = [[*r.pose[:2], r.f_px, r.score] for r in runs]
            record["spread_m"] = float(max(np.hypot(*(xy[i] - xy[j])) for i in range(3) for j in range(i + 1, 3)))
            line = (f"err {before['error_m']:7.0f} m  conf {before['confidence']:.3f}  spread {record['spread_m']:6.0f} m"
                    f"  scores {np.round([r.score for r in runs], 3)}")
        record["seconds"] = time.perf_counter() - t0
        result.append(record)
        print(f"{it.key:36s} {line}  {record['seconds']:.1f} s", flush=True)
    with open(out, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
