"""How far the answer moves when its focal length is held a few per cent off (a probe on stored fov-unknown rows,
2026-12-05).

``python experiments/ch1/fov-sensitivity/probe.py OUT.json ROWS.json [ROWS.json ...] [--delta 0.05]``

With the fov unknown, a narrow view of far ridges hardly pins the camera's distance along the view: a focal length a
few per cent off trades against it (``../fov-unknown-range/``). Where it does, the answer's position is uncertain by
more than its margin shows. For each row (its answer pose and fov), the pose is fitted again by the refinement's
least squares (x, y, pan, tilt, swing free) with the focal length held at f (1 - delta) and f (1 + delta); reported:
how far each fit moves the answer (m) and its score against the answer's.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, with_terrain
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer.refinement import RefineParams, _least_squares, _pose_of
from skyrender.localizer.verification import score_skylines
from skyrender.render.skyline import render_skylines


def scores_of(terrain, qs: np.ndarray, intrinsics: Intrinsics, sky, weights, sp) -> np.ndarray:
    poses, k = _pose_of(terrain.dem, qs, intrinsics)
    rendered = render_skylines(terrain, poses, intrinsics, per_pose_intrinsics=k)
    return score_skylines(rendered, sky, weights, sp)[0]


def scan(terrain, q0, factors, intr, sky, weights, nfev, sp, row, key, error) -> dict:
    """The answer fitted again (x, y, pan, tilt, swing) at each focal factor; the best-scoring fit's error."""
    fits = []
    for s in factors:
        q = q0.copy()
        q[5] = q0[5] * s
        fits.append(_least_squares(terrain, q, [0, 1, 2, 3, 4], intr, sky, weights, nfev, sp,
                                   max_height=row["height_m"], focal_range=(q[5], 0.0))[0])
    fits = np.array(fits)
    score = scores_of(terrain, np.vstack([q0[None], fits]), intr, sky, weights, sp)
    truth = np.asarray(row["truth_xy"])
    errors = [float(np.hypot(*(q[:2] - truth))) for q in fits]
    b = int(np.argmin(score[1:]))
    fov = [float(np.degrees(2 * np.arctan(intr.width / 2 / q[5]))) for q in fits]
    print(f"{key:32s} err {error:6.0f} -> {errors[b]:6.0f} m  fov {row['fov']:5.1f} -> {fov[b]:5.1f}  "
          f"score {score[0]:.2f} -> {score[1 + b]:.2f}  (per factor: "
          + " ".join(f"{e:.0f}/{s:.2f}" for e, s in zip(errors, score[1:])) + ")", flush=True)
    return {"photo": key, "error_m": error, "fov": row["fov"], "factors": list(factors), "errors_m": errors,
            "fovs": fov, "scores": [float(v) for v in score[1:]], "answer_score": float(score[0])}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("rows", nargs="+")
    ap.add_argument("--delta", type=float, default=0.05)
    ap.add_argument("--scan", type=float, nargs="*", default=None,
                    help="instead: fit at these focal factors and report the best's error (rows within --near-m)")
    ap.add_argument("--near-m", type=float, default=3000.0)
    a = ap.parse_args()
    items = {it.key: it for side in ("train", "dev", "validation") for it in items_on_side(side)
             if it.key.startswith("ch1/")}
    params = LocalizeParams.for_photos()
    sp, nfev = params.score, RefineParams().max_nfev
    out = []
    for path in a.rows:
        rows = json.load(open(path))["photos"]
        for row, it, terrain in with_terrain(rows, items):
            image, sky, weights = photo_skyline(it, params)
            H, W = image.shape[:2]
            x, y, _, pan, tilt, swing = row["pose"]
            f = W / 2.0 / math.tan(math.radians(row["fov"]) / 2.0)
            intr = Intrinsics(W, H, f, W / 2.0, H / 2.0)
            q0 = np.array([x, y, pan, tilt, swing, f, row["height_m"]])
            error = row.get("error_m", row.get("withheld_error_m"))
            if a.scan is not None:
                if error > a.near_m:
                    continue
                out.append(scan(terrain, q0, a.scan, intr, sky, weights, nfev, sp, row, it.key, error))
                continue
            fits = [q0]
            for s in (1.0 - a.delta, 1.0 + a.delta):
                q = q0.copy()
                q[5] = f * s
                fitted, _ = _least_squares(terrain, q, [0, 1, 2, 3, 4], intr, sky, weights, nfev, sp,
                                           max_height=row["height_m"], focal_range=(q[5], 0.0))
                fits.append(fitted)
            fits = np.array(fits)
            score = scores_of(terrain, fits, intr, sky, weights, sp)
            shift = [float(np.hypot(*(q[:2] - q0[:2]))) for q in fits[1:]]
            rec = {"photo": it.key, "error_m": error, "confidence": row["confidence"], "fov": row["fov"],
                   "shift_m": shift, "score": [float(s) for s in score]}
            out.append(rec)
            print(f"{it.key:32s} err {error:8.0f} conf {row['confidence']:.3f} fov {row['fov']:5.1f} "
                  f"shift {shift[0]:6.0f} {shift[1]:6.0f} m  score {score[0]:.2f} -> {score[1]:.2f} {score[2]:.2f}",
                  flush=True)
    json.dump(out, open(a.out, "w"), indent=1)


if __name__ == "__main__":
    main()
