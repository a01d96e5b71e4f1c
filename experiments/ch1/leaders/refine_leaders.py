"""For wrong training-side photos whose near-truth pose leads a (tilt, window) list of the far-horizon search: every
list leader moved on the re-ranking grid, and each leader within 1 km of the truth refined; its refined score beside
the answer's (the shipped preset's rows, ``../rerank-all/``). Would it win if refined? Needs ``leaders.patch``
applied (``horizon_poses`` giving the ranks in lists). ``python experiments/ch1/leaders/refine_leaders.py KEY ...``
from the repository root → ``refine_leaders.txt``."""
import json
import math
import sys
from dataclasses import replace

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, with_place
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer.horizon_search import horizon_poses, standable_centres
from skyrender.localizer.pipeline import rerank_columns
from skyrender.localizer.refinement import local_rescore, refine_pose


def main(keys: list[str]) -> None:
    rows = {}
    for side in ("train", "dev"):
        with open(f"experiments/ch1/rerank-all/bench-real-{side}-rerank-all.json") as f:
            rows.update({r["photo"]: r for r in json.load(f)["photos"] if r["fov_mode"] == "known"})
    items = [it for side in ("train", "dev") for it in items_on_side(side) if it.key in keys]
    params = LocalizeParams.for_photos()
    in_list = replace(params.horizon, cost_ranking="in_list")
    for _, it, (dem, terrain, model) in with_place(items):
        image, sky, weights = photo_skyline(it, params)
        H, W = image.shape[:2]
        k = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
        poses, rank = horizon_poses(model.horizons, sky, weights, k, dem, 2.0, in_list,
                                    centres=standable_centres(model.horizons, dem, params.max_ground_slope_deg))
        tx, ty = dem.from_lonlat(it.lon, it.lat)
        d = np.hypot(poses[:, 0] - tx, poses[:, 1] - ty)
        leaders = np.flatnonzero(rank < 1)
        near = leaders[d[leaders] < 1000]
        moved, score = local_rescore(terrain, poses[leaders], k, 2.0, sky, weights, params.rerank_half_m,
                                     params.rerank_grid, rerank_columns(params, W), params.score)
        order = np.argsort(score)
        row = rows[it.key]
        print(f"{it.key}: {len(leaders)} list leaders, {len(near)} within 1 km; answer {row['error_m']:.0f} m "
              f"scored {row['best_score']:.3f}")
        for j in near:
            i = int(np.flatnonzero(leaders == j)[0])
            ref = refine_pose(terrain, moved[i], k, 2.0, sky, weights, f_px=k.f_px, params=params.score,
                              refine=params.refine)
            err = math.hypot(ref.pose[0] - tx, ref.pose[1] - ty)
            print(f"   leader {d[j]:.0f} m off (rank by re-ranked score {int(np.flatnonzero(order == i)[0]) + 1} of "
                  f"{len(leaders)}), refined {err:.0f} m off, score {ref.score:.3f} -> "
                  f"{'WINS' if ref.score < row['best_score'] else 'loses'}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
