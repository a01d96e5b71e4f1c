"""End to end: bench-localize's views rendered with two cables across the sky, localized (render preset,
no prior, fov known) — run with this code and with the code before the cables (``PYTHONPATH=<worktree>``).

``python experiments/photos/cables/localize_probe.py OUT.json [--sky overcast] [--views 10]``
"""

from __future__ import annotations

import argparse
import json

from skyrender.benchmarks.views import BENCH_FOV_DEG, bench_localize_views
from skyrender.dem.synthetic import fractal_terrain
from skyrender.evaluate import git_commit, position_errors
from skyrender.localizer import localize
from skyrender.model import build_model
from skyrender.render import Terrain
from skyrender.render.photo import Look, render_photo


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("out")
    parser.add_argument("--sky", default="overcast")
    parser.add_argument("--views", type=int, default=10)
    args = parser.parse_args()
    dem = fractal_terrain()
    terrain = Terrain(dem)
    model = build_model(dem, terrain=terrain)
    intrinsics, sample, _ = bench_localize_views(terrain, model, args.views, 1)  # bench-localize's views
    rows = []
    for i, pose in enumerate(sample.poses):
        photo = render_photo(terrain, pose, intrinsics, Look(seed=i, sky=args.sky, power_lines=2))
        r = localize(photo.image, model, 2.0, BENCH_FOV_DEG, terrain=terrain)
        error = float(position_errors(r.pose, pose.array())[0]) if r.localized else None
        rows.append({"view": i, "status": r.status, "error_m": error, "confidence": r.confidence,
                     "seconds": r.seconds})
        print(rows[-1], flush=True)
    right = sum(1 for r in rows if r["error_m"] is not None and r["error_m"] <= 200)
    summary = {"commit": git_commit(), "sky": args.sky, "views": len(rows), "within_200m": right, "rows": rows}
    with open(args.out, "w") as f:
        json.dump(summary, f, indent=1)
    print(f"{right} of {len(rows)} within 200 m")


if __name__ == "__main__":
    main()
