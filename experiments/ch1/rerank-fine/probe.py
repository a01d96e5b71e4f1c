"""Would a finer second re-ranking put the far-horizon pose near the truth among the refined? (a probe)

``python experiments/ch1/rerank-fine/probe.py OUT.json [--sides train dev]``

For each CH1 training-side photo (fov given), the photo preset's far-horizon poses and their re-ranking as shipped
(every pose moved to the best of a 7 x 7 grid +-300 m, scored on every 32nd column), then a second stage: the best
``TOP`` by that score moved again over a finer grid (5 x 5, +-100 m) scored on every 8th column. Per photo, the rank of
the first pose within 250 m / 1 km of the truth by the shipped re-ranked score, by the search's cost (the second
ranking) and by the second stage's score (the rest after the ``TOP`` in their shipped order). The preset refines the
best 8 by each of its two rankings.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, with_place
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.diagnostics.candidates import far_horizon_candidates, first_rank
from skyrender.localizer import LocalizeParams
from skyrender.localizer.pipeline import rerank_far_horizon
from skyrender.localizer.refinement import local_rescore

TOP, GRID, HALF_M, STRIDE = 64, 5, 100.0, 8


def main(out: str, sides=("train", "dev")) -> None:
    params = LocalizeParams.for_photos()
    items = [it for s in sides for it in items_on_side(s) if it.key.startswith("ch1/")]
    rows = []
    for n, it, (dem, terrain, model) in with_place(items):
        t0 = time.perf_counter()
        image, sky, weights = photo_skyline(it, params)
        H, W = image.shape[:2]
        k = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
        poses, cost, score, trusted = far_horizon_candidates(model, dem, terrain, sky, weights, k, 2.0, params)
        pick, moved, rescored = rerank_far_horizon(terrain, poses, score, trusted, k, 2.0, sky, weights, params)
        second = trusted[pick]
        t1 = time.perf_counter()
        top = np.argsort(rescored, kind="stable")[:TOP]
        fine_moved, fine = local_rescore(terrain, moved[top], k, 2.0, sky, weights, HALF_M, GRID, STRIDE, params.score)
        t2 = time.perf_counter()
        tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
        d_moved = np.hypot(moved[:, 0] - tx, moved[:, 1] - ty)
        d_fine = d_moved.copy()
        d_fine[top] = np.hypot(fine_moved[:, 0] - tx, fine_moved[:, 1] - ty)
        order_shipped = np.argsort(rescored, kind="stable")
        order_fine = np.r_[top[np.argsort(fine, kind="stable")], order_shipped[TOP:]]
        order_cost = np.argsort(second, kind="stable")
        row = {"photo": it.key, "poses": int(len(poses)), "seconds_rerank": t1 - t0, "seconds_fine": t2 - t1}
        for r in (250.0, 1000.0):
            key = f"{r:.0f}"
            row[f"rank_shipped_{key}"] = first_rank(order_shipped, d_moved, r)
            row[f"rank_cost_{key}"] = first_rank(order_cost, d_moved, r)
            row[f"rank_fine_{key}"] = first_rank(order_fine, d_fine, r)
        rows.append(row)
        print(f"[{n + 1}/{len(items)}] {it.key}: 1 km shipped {row['rank_shipped_1000']} cost {row['rank_cost_1000']} "
              f"fine {row['rank_fine_1000']}; 250 m shipped {row['rank_shipped_250']} fine {row['rank_fine_250']}; "
              f"fine stage {t2 - t1:.1f} s", flush=True)
        with open(out, "w") as f:
            json.dump({"top": TOP, "grid": GRID, "half_m": HALF_M, "stride": STRIDE, "rows": rows}, f, indent=1)

    def among(rank, cost):
        return (rank is not None and rank <= 8) or (cost is not None and cost <= 8)

    for r in ("250", "1000"):
        shipped = sum(among(x[f"rank_shipped_{r}"], x[f"rank_cost_{r}"]) for x in rows)
        fine = sum(among(x[f"rank_fine_{r}"], x[f"rank_cost_{r}"]) for x in rows)
        anywhere = sum(x[f"rank_shipped_{r}"] is not None for x in rows)
        print(f"within {r} m: a pose at all {anywhere}; among the 8 + 8 refined: shipped {shipped}, fine {fine}")


if __name__ == "__main__":
    main(sys.argv[1], tuple(sys.argv[2:]) or ("train", "dev"))
