"""``make bench-localize``: the localizer's speed and accuracy on rendered views.

Prints, in one run on the synthetic 600² @ 50 m scene:

1. Hypotheses per second of the vectorised three-point solver against a
   per-hypothesis ``scipy.optimize.least_squares`` loop (the paper's approach:
   one Levenberg–Marquardt fit per hypothesis, here from the same closed-form
   seed), on the same hypotheses, and the ratio.
2. End-to-end localization of rendered photographs (views from
   :func:`~skyrender.benchmarks.views.sample_views`, skylines extracted from the
   photos): seconds with a prior ("the peak the camera is turned towards is in
   view") and the probabilistic order, with that prior and no order, and with
   no prior; position and orientation errors; localized / abstained / wrong.

Usage: ``python -m skyrender.benchmarks.localizer [--views N] [--seed S]``
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from ..camera import CURVATURE_COEFF, Intrinsics, Pose, project
from ..dem.synthetic import fractal_terrain
from ..evaluate import orientation_errors, position_errors
from ..features import extract_skyline
from ..localizer import LocalizeParams, localize
from ..localizer.hypotheses import generate_hypotheses
from ..localizer.pipeline import image_peaks
from ..localizer.pose_solver import (
    _world_directions,
    angles_from_rotations,
    image_bearings,
    resection_2d,
    rotations_from_bearings,
    solve_poses,
)
from ..model import build_model
from ..render import Terrain, render_skylines
from ..render.photo import Look, render_photo
from .views import sample_views

#: A localization counts as wrong (not merely imprecise) beyond this position error.
WRONG_M = 100.0


def loop_solve(dem, uv: np.ndarray, world: np.ndarray, height: float, intr: Intrinsics) -> tuple[np.ndarray, float]:
    """Baseline: one least_squares fit of (x, y, pan, tilt, swing) to the six
    reprojection residuals, seeded by the closed-form resection and rotation."""
    b = image_bearings(uv[None], intr.f_px, intr.cx, intr.cy)
    dots = [float(b[0, i] @ b[0, j]) for i, j in ((0, 1), (1, 2))]
    xy = resection_2d(world[None, :, :2], np.arccos(dots[0:1]), np.arccos(dots[1:2]))[0]
    if not np.all(np.isfinite(xy)) or not dem.contains(*xy):
        return np.full(6, np.nan), np.inf
    centre = np.r_[xy, dem.ground(*xy) + height]
    angles = angles_from_rotations(rotations_from_bearings(b, _world_directions(world[None], centre[None],
                                                                                  CURVATURE_COEFF)))[0]

    def residuals(q):
        z = dem.ground(q[0], q[1])
        if not np.isfinite(z):
            return np.full(6, 1e3)
        p, front = project(world, Pose(q[0], q[1], float(z) + height, q[2], q[3], q[4]), intr)
        return np.where(front[:, None], p - uv, 1e3).ravel()

    fit = least_squares(residuals, np.r_[xy, angles], x_scale=np.array([100.0, 100.0, 1.0, 1.0, 1.0]))
    q = fit.x
    return np.r_[q[0], q[1], dem.ground(q[0], q[1]) + height, q[2:]], float(np.sqrt(np.mean(fit.fun**2) * 2))


def solver_benchmark(terrain, model, intr, pose, n_loop: int = 300) -> dict:
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
    for i in pick:
        loop_solve(terrain.dem, img[i], world[i], 2.0, intr)
    loop = n_loop / (time.perf_counter() - t)
    return {"hypotheses": n, "vectorised_per_s": vec, "loop_per_s": loop, "ratio": vec / loop}


def _errors(result, truth: np.ndarray) -> tuple[float, float]:
    return float(position_errors(result.pose, truth)[0]), float(orientation_errors(result.pose, truth)[0])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m skyrender.benchmarks.localizer", description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)

    dem = fractal_terrain()
    t0 = time.perf_counter()
    terrain = Terrain(dem)
    model = build_model(dem, terrain=terrain)
    intr = Intrinsics.from_fov(60.0, 640, 480)
    print(f"{dem.describe()}\n{model.summary()}; ready in {time.perf_counter() - t0:.1f} s ({terrain.variant}, 2 cores)")
    sample = sample_views(terrain, model, intr, args.views, seed=args.seed)
    print(f"{len(sample.poses)} views (camera 2 m up, turned towards a pivot on its skyline 2-15 km away, "
          f">= 3 of the 8 largest skyline peaks on model peaks): {sample.drawn} random views drawn to find them")

    s = solver_benchmark(terrain, model, intr, sample.poses[0])
    print(f"\nsolver: {s['hypotheses']} hypotheses; vectorised {s['vectorised_per_s']:,.0f} hyp/s; "
          f"least_squares loop {s['loop_per_s']:,.0f} hyp/s; ratio {s['ratio']:.0f}x "
          f"(targets: >= 100,000 hyp/s, >= 100x)")

    configs = {"prior + order": ({}, True), "prior, no order": ({}, False), "no prior": (None, True)}
    rows = {name: [] for name in configs}
    print(f"\n{'view':>4} {'extract s':>9} | " + " | ".join(f"{n:^28}" for n in configs))
    for i, (pose, target) in enumerate(zip(sample.poses, sample.targets)):
        photo = render_photo(terrain, pose, intr, Look(seed=i))
        t = time.perf_counter()
        extracted = extract_skyline(photo.image)
        t_extract = time.perf_counter() - t
        cells = []
        for name, (prior, ordered) in configs.items():
            p = None if prior is None else {"ids": [int(model.features.id[target])]}
            r = localize(photo.image, model, 2.0, 60.0, p, terrain=terrain, skyline=extracted,
                         params=replace(LocalizeParams(), ordered=ordered))
            if r.localized:
                d_pos, d_ang = _errors(r, pose.array())
                rows[name].append((r.seconds, d_pos, d_ang, r.hypotheses))
                cells.append(f"{r.seconds:6.1f} s {d_pos:7.1f} m {d_ang:5.2f} deg")
            else:
                rows[name].append((r.seconds, np.nan, np.nan, r.hypotheses))
                cells.append(f"{r.seconds:6.1f} s    abstained    ")
        print(f"{i:>4} {t_extract:9.1f} | " + " | ".join(f"{c:^28}" for c in cells), flush=True)

    print()
    for name, data in rows.items():
        a = np.array(data, dtype=np.float64)
        secs, pos, ang = a[:, 0], a[:, 1], a[:, 2]
        ok = np.isfinite(pos)
        right = ok & (pos <= WRONG_M)
        line = (f"{name:>16}: seconds median {np.median(secs):.1f} max {secs.max():.1f}; localized {ok.sum()}/{len(a)} "
                f"(wrong > {WRONG_M:.0f} m: {(ok & ~right).sum()}, abstained {(~ok).sum()})")
        if right.any():
            line += (f"; position error of the right ones min/mean/max {pos[right].min():.1f}/{pos[right].mean():.1f}/"
                     f"{pos[right].max():.1f} m, orientation mean {ang[right].mean():.3f} deg")
        print(line)
    print("targets (no prior): median <= 5 s, max <= 20 s; position min/mean/max <= 3/15/50 m, orientation mean "
          "<= 0.1 deg, every view localized")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
