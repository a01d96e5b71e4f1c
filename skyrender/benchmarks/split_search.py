"""``make bench-split``: does one localization's hypothesis search pay on Dask workers?

``python -m skyrender.benchmarks.split_search [--workers 2] [--views 3]``

On the synthetic 600² @ 50 m scene, in one run: the three-point solver on one view's
400,000 hypotheses, in this process (:func:`solve_poses`) and split over a local Dask
cluster of ``--workers`` single-threaded processes (:class:`skyrender.scale.SplitSolver`),
the poses compared; then whole localizations (no prior, the photo in, the pose out) both
ways. The cluster's start (and the DEM sent to each worker) is timed apart: a user with a
cluster pays it once. Writes ``experiments/synthetic600/bench-split.json``.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from ..camera import Intrinsics
from ..dem.synthetic import fractal_terrain
from ..evaluate import REPO
from ..localizer import localize
from ..localizer.hypotheses import generate_hypotheses
from ..localizer.params import LocalizeParams
from ..localizer.pipeline import image_peaks
from ..localizer.pose_solver import solve_poses
from ..model import build_model
from ..render import Terrain, render_skylines
from ..render.photo import Look, render_photo
from ..scale import SplitSolver, dask_client
from . import median_seconds, write_figures
from .views import sample_views


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m skyrender.benchmarks.split_search", description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--views", type=int, default=3)
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "synthetic600", "bench-split.json"))
    args = parser.parse_args(argv)

    dem = fractal_terrain()
    terrain = Terrain(dem)
    model = build_model(dem, terrain=terrain)
    intr = Intrinsics.from_fov(60.0, 640, 480)
    sample = sample_views(terrain, model, intr, args.views, seed=1)
    peaks = image_peaks(render_skylines(terrain, sample.poses[0], intr), LocalizeParams())
    uv = np.array([[p.u, p.v] for p in peaks])
    hyps = generate_hypotheses(uv[:, 0], np.array([p.size for p in peaks]), model)
    n = min(len(hyps), 400_000)
    img, world = uv[hyps.image[:n]], model.features.xyz[hyps.features[:n]]
    photos = [render_photo(terrain, pose, intr, Look(seed=i)).image for i, pose in enumerate(sample.poses)]
    print(f"{n} hypotheses of view 0; {len(photos)} views; {os.cpu_count()} cores")

    local_s = median_seconds(lambda: solve_poses(dem, img, world, 2.0, intr.f_px, intr.cx, intr.cy), 3)
    local_runs = [localize(photo, model, 2.0, 60.0, terrain=terrain) for photo in photos]
    t = time.perf_counter()
    with dask_client(workers=args.workers) as client:
        split = SplitSolver(client, dem)
        start_s = time.perf_counter() - t
        split_s = median_seconds(lambda: split(dem, img, world, 2.0, intr.f_px, intr.cx, intr.cy), 3)
        same = all(np.array_equal(a, b, equal_nan=True) for a, b in
                   zip(split(dem, img, world, 2.0, intr.f_px, intr.cx, intr.cy),
                       solve_poses(dem, img, world, 2.0, intr.f_px, intr.cx, intr.cy)))
        split_runs = [localize(photo, model, 2.0, 60.0, terrain=terrain, solver=split) for photo in photos]
    same_poses = all(np.array_equal(a.pose, b.pose, equal_nan=True) for a, b in zip(local_runs, split_runs))
    local_loc = [r.seconds for r in local_runs]
    split_loc = [r.seconds for r in split_runs]
    solver_local = [r.stats.seconds.get("pose_solver", 0.0) for r in local_runs]
    solver_split = [r.stats.seconds.get("pose_solver", 0.0) for r in split_runs]
    print(f"cluster start ({args.workers} workers) and the DEM sent to each: {start_s:.1f} s")
    print(f"solver, {n} hypotheses: this process {local_s:.2f} s; {args.workers} workers {split_s:.2f} s; "
          f"speed-up {local_s / split_s:.2f}x; identical poses and residuals: {same}")
    print(f"localization (no prior), seconds per view: this process {np.round(local_loc, 1).tolist()}, "
          f"{args.workers} workers {np.round(split_loc, 1).tolist()}; speed-up of the median "
          f"{np.median(local_loc) / np.median(split_loc):.2f}x; same poses: {same_poses}")
    print(f"  of which the solver: {np.round(solver_local, 2).tolist()} -> {np.round(solver_split, 2).tolist()} s")
    path = write_figures(args.out, {"hypotheses": n, "cluster_start_s": start_s, "solver_local_s": local_s,
                                    "solver_split_s": split_s, "solver_speedup": local_s / split_s, "identical": same,
                                    "localize_local_s": local_loc, "localize_split_s": split_loc,
                                    "solver_stage_local_s": solver_local, "solver_stage_split_s": solver_split,
                                    "same_poses": same_poses}, workers=args.workers, views=args.views)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
