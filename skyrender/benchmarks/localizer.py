"""``make bench-localize``: the localizer's speed and accuracy on rendered views.

Prints, in one run on the synthetic 600² @ 50 m scene, and writes to
``experiments/synthetic600/bench-localize.json`` (with the commit, variant and CPU count):

1. Hypotheses per second of the vectorised three-point solver against a
   per-hypothesis ``scipy.optimize.least_squares`` loop (the paper's approach: one
   Levenberg–Marquardt fit per hypothesis) doing the same work: the same closed-form
   seed, the same cheap plausibility screening first (a hypothesis the vectorised
   solver drops after the closed form costs the loop no fit either), LM with a
   forward-difference Jacobian (the vectorised solver's is one too) and an evaluation
   cap; the same hypotheses, timed with the same clock.
2. End-to-end localization of rendered photographs (views from
   :func:`~skyrender.benchmarks.views.sample_views`): seconds as a user waits —
   the photo in, skyline extraction included (``localize`` on the image) — with a prior
   ("the peak the camera is turned towards is in view") and the probabilistic order,
   with that prior and no order, and with no prior; per-stage seconds; position and
   orientation errors; localized / abstained / wrong. Model loading from disk is timed
   once (the CLI pays it per call).

Usage: ``python -m skyrender.benchmarks.localizer [--views N] [--seed S]``
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from ..camera import CURVATURE_COEFF, Intrinsics, Pose, project
from ..dem.synthetic import fractal_terrain
from ..evaluate import REPO, orientation_errors, position_errors
from ..localizer import LocalizeParams, localize
from ..localizer.hypotheses import generate_hypotheses
from ..localizer.pipeline import image_peaks
from ..localizer.pose_solver import (
    _pair_angles,
    _world_directions,
    angles_from_rotations,
    image_bearings,
    plausible_positions,
    resection_2d,
    rotations_from_bearings,
    solve_poses,
)
from ..model import build_model, load_model, save_model
from ..render import Terrain, render_skylines
from . import write_figures
from .views import BENCH_FOV_DEG, bench_localize_views

#: A localization counts as wrong (not merely imprecise) beyond this position error.
WRONG_M = 100.0


def loop_solve(dem, uv: np.ndarray, world: np.ndarray, height: float, intr: Intrinsics,
               max_nfev: int = 50) -> tuple[np.ndarray, float]:
    """Baseline: one Levenberg–Marquardt fit (``least_squares(method="lm")``) of
    (x, y, pan, tilt, swing) to the six reprojection residuals, seeded by the closed-form
    resection and rotation, after the vectorised solver's plausibility screening."""
    b = image_bearings(uv[None], intr.f_px, intr.cx, intr.cy)
    measured = _pair_angles(b)
    xy = resection_2d(world[None, :, :2], measured[:, 0], measured[:, 1])
    if not plausible_positions(dem, xy, world[None], measured)[0]:
        return np.full(6, np.nan), np.inf
    xy = xy[0]
    centre = np.r_[xy, dem.ground(*xy) + height]
    angles = angles_from_rotations(rotations_from_bearings(b, _world_directions(world[None], centre[None],
                                                                                  CURVATURE_COEFF)))[0]

    def residuals(q):
        z = dem.ground(q[0], q[1])
        if not np.isfinite(z):
            return np.full(6, 1e3)
        p, front = project(world, Pose(q[0], q[1], float(z) + height, q[2], q[3], q[4]), intr)
        return np.where(front[:, None], p - uv, 1e3).ravel()

    fit = least_squares(residuals, np.r_[xy, angles], method="lm", x_scale=np.array([100.0, 100.0, 1.0, 1.0, 1.0]),
                        max_nfev=max_nfev)
    q = fit.x
    return np.r_[q[0], q[1], dem.ground(q[0], q[1]) + height, q[2:]], float(np.sqrt(np.mean(fit.fun**2) * 2))


def solver_benchmark(terrain, model, intr, pose, n_loop: int = 2000) -> dict:
    """Hypotheses/s of the vectorised solver and of the loop, on one view's hypotheses."""
    sky = render_skylines(terrain, pose, intr)
    peaks = image_peaks(sky, LocalizeParams())
    uv = np.array([[p.u, p.v] for p in peaks])
    hyps = generate_hypotheses(uv[:, 0], np.array([p.size for p in peaks]), model)
    n = min(len(hyps), 400_000)
    img, world = uv[hyps.image[:n]], model.features.xyz[hyps.features[:n]]
    solve_poses(terrain.dem, img[:1000], world[:1000], 2.0, intr.f_px, intr.cx, intr.cy)  # warm caches
    t = time.perf_counter()
    solve_poses(terrain.dem, img, world, 2.0, intr.f_px, intr.cx, intr.cy)
    vec = n / (time.perf_counter() - t)
    pick = np.linspace(0, n - 1, n_loop).astype(np.int64)
    t = time.perf_counter()
    fitted = 0
    for i in pick:
        fitted += np.isfinite(loop_solve(terrain.dem, img[i], world[i], 2.0, intr)[1])
    loop = n_loop / (time.perf_counter() - t)
    return {"hypotheses": n, "vectorised_per_s": vec, "loop_hypotheses": n_loop, "loop_fitted": int(fitted),
            "loop_per_s": loop, "ratio": vec / loop}


def _errors(result, truth: np.ndarray) -> tuple[float, float]:
    return float(position_errors(result.pose, truth)[0]), float(orientation_errors(result.pose, truth)[0])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m skyrender.benchmarks.localizer", description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "synthetic600", "bench-localize.json"))
    args = parser.parse_args(argv)

    dem = fractal_terrain()
    t0 = time.perf_counter()
    terrain = Terrain(dem)
    model = build_model(dem, terrain=terrain)
    build_s = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        save_model(model, os.path.join(tmp, "model"))
        t = time.perf_counter()
        load_model(os.path.join(tmp, "model"), dem=dem)
        load_s = time.perf_counter() - t
    intr, sample, photos = bench_localize_views(terrain, model, args.views, args.seed)
    print(f"{dem.describe()}\n{model.summary()}; ready in {build_s:.1f} s ({terrain.variant}, {os.cpu_count()} cores); "
          f"loading the saved model (DEM apart): {load_s:.2f} s")
    print(f"{len(sample.poses)} views (camera 2 m up, turned towards a pivot on its skyline 2-15 km away, "
          f">= 3 of the 8 largest skyline peaks on model peaks): {sample.drawn} random views drawn to find them")

    s = solver_benchmark(terrain, model, intr, sample.poses[0])
    print(f"\nsolver: {s['hypotheses']} hypotheses; vectorised {s['vectorised_per_s']:,.0f} hyp/s; least_squares "
          f"loop (screened, LM, <= 50 evaluations; {s['loop_fitted']} of {s['loop_hypotheses']} fitted) "
          f"{s['loop_per_s']:,.0f} hyp/s; ratio {s['ratio']:.0f}x (targets: >= 100,000 hyp/s, >= 100x)")

    configs = {"prior + order": ({}, True), "prior, no order": ({}, False), "no prior": (None, True)}
    rows = {name: [] for name in configs}
    print("\nseconds: photo in, pose out (skyline extraction included)")
    print(f"{'view':>4} | " + " | ".join(f"{n:^28}" for n in configs))
    for i, (pose, target, photo) in enumerate(zip(sample.poses, sample.targets, photos)):
        cells = []
        for name, (prior, ordered) in configs.items():
            p = None if prior is None else {"ids": [int(model.features.id[target])]}
            r = localize(photo, model, 2.0, BENCH_FOV_DEG, p, terrain=terrain,
                         params=replace(LocalizeParams(), ordered=ordered))
            d_pos, d_ang = _errors(r, pose.array()) if r.localized else (np.nan, np.nan)
            rows[name].append({"view": i, "seconds": r.seconds, "position_error_m": d_pos, "orientation_error_deg": d_ang,
                               "localized": r.localized, "hypotheses": r.hypotheses,
                               "stage_seconds": dict(r.stats.seconds) if r.stats else {}})
            cells.append(f"{r.seconds:6.1f} s {d_pos:7.1f} m {d_ang:5.2f} deg" if r.localized
                         else f"{r.seconds:6.1f} s    abstained    ")
        print(f"{i:>4} | " + " | ".join(f"{c:^28}" for c in cells), flush=True)

    print()
    summary = {}
    for name, data in rows.items():
        secs = np.array([d["seconds"] for d in data])
        pos = np.array([d["position_error_m"] for d in data], dtype=np.float64)
        ang = np.array([d["orientation_error_deg"] for d in data], dtype=np.float64)
        ok = np.isfinite(pos)
        right = ok & (pos <= WRONG_M)
        stages = sorted({k for d in data for k in d["stage_seconds"]})
        median_stage = {k: float(np.median([d["stage_seconds"].get(k, 0.0) for d in data])) for k in stages}
        summary[name] = {"seconds_median": float(np.median(secs)), "seconds_max": float(secs.max()),
                         "localized": int(ok.sum()), "wrong": int((ok & ~right).sum()), "abstained": int((~ok).sum()),
                         "stage_seconds_median": median_stage}
        line = (f"{name:>16}: seconds median {np.median(secs):.1f} max {secs.max():.1f}; localized {ok.sum()}/{len(data)} "
                f"(wrong > {WRONG_M:.0f} m: {(ok & ~right).sum()}, abstained {(~ok).sum()})")
        if right.any():
            summary[name].update(position_m=[float(pos[right].min()), float(pos[right].mean()), float(pos[right].max())],
                                 orientation_deg_mean=float(ang[right].mean()))
            line += (f"; position error of the right ones min/mean/max {pos[right].min():.1f}/{pos[right].mean():.1f}/"
                     f"{pos[right].max():.1f} m, orientation mean {ang[right].mean():.3f} deg")
        print(line)
        print(f"{'':>16}  median stage seconds: " + ", ".join(f"{k} {v:.2f}" for k, v in median_stage.items() if v >= 0.005))
    print("targets (no prior): median <= 5 s, max <= 20 s; position min/mean/max <= 3/15/50 m, orientation mean "
          "<= 0.1 deg, every view localized")
    path = write_figures(args.out, {"model_build_s": build_s, "model_load_s": load_s, "solver": s, "summary": summary,
                                    "views": rows}, views=args.views, seed=args.seed)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
