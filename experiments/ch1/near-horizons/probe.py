"""Would horizons with the near terrain, on a fine grid, find the near-skyline photos? (a feasibility probe, 2026-12-05)

``python experiments/ch1/near-horizons/probe.py OUT.json [--random N] [--near-m M] [--true-skyline]``

For the 9 training-side photos whose skyline is mostly terrain within 3 km (``../near-skylines/``), horizons
(1 deg bins, the camera 2 m above the ground) are rendered at two sets of centres of the photo's search
window: a 100 m grid within 500 m of the true position (121 centres) and N centres drawn uniformly over the
window (seeded). The photo preset's far-horizon matching (``horizon_poses``: tilts -10..30, offset + slope,
every window) ranks all (centre, azimuth) pairs; reported: the rank by cost of the first pose within 250 m of
the truth, and of the best pose among the near-truth grid, out of all, once with the near terrain (from
``--near-m``, default 30 m) and once from 300 m as the photo model's far horizons are.
A dense search of the whole window on that grid would hold ~1.5 M centres: a near-truth pose ranked r among
N random ones would rank about r * 1.5 M / N there.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from skyrender.benchmarks.real_localize import place_window, places_of, true_extraction
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.dem import load_dem
from skyrender.diagnostics.oracle import DEM_DIR, tiles_around
from skyrender.features import extract_skyline, load_photo
from skyrender.localizer import LocalizeParams
from skyrender.localizer.horizon_search import horizon_poses
from skyrender.localizer.pipeline import column_weights
from skyrender.model.horizons import Horizons
from skyrender.render import Terrain
from skyrender.render.horizon import render_horizons

NEAR_SKYLINES = ["ch1/IMG_4923_01024", "ch1/IMG_5141_01024", "ch1/IMG_5181_01024", "ch1/IMG_5195_01024",
                 "ch1/2011-04-30_18-37-52_01024", "ch1/2011-10-01_17-15-04_01024", "ch1/2011-10-01_17-19-13_01024",
                 "ch1/IMG_5045_01024", "ch1/IMG_5156_01024"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--random", type=int, default=20000)
    ap.add_argument("--near-m", type=float, default=30.0)
    ap.add_argument("--true-skyline", action="store_true")
    a = ap.parse_args()
    items = {it.key: it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")}
    _, centres_of = places_of(items.values())
    place_of, _ = places_of(items.values())
    params = LocalizeParams.for_photos()
    search = replace(params.horizon, per_window=5000)
    rows = []
    for key in NEAR_SKYLINES:
        it = items[key]
        window = place_window(*centres_of[place_of[key]])
        dem = load_dem(tiles_around(it.lat, it.lon, DEM_DIR), bounds=window)
        terrain = Terrain(dem)
        tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
        image = load_photo(it.image_path)
        H, W = image.shape[:2]
        ext = true_extraction(it, H) if a.true_skyline else extract_skyline(image, params.skyline_params())
        weights = column_weights(ext.confidence)
        K = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
        xmin, xmax, ymin, ymax = dem.extent
        rng = np.random.default_rng(0)
        far = np.column_stack([rng.uniform(xmin + 2000, xmax - 2000, a.random), rng.uniform(ymin + 2000, ymax - 2000, a.random)])
        g = np.arange(-500.0, 501.0, 100.0)
        near = np.column_stack([tx + np.repeat(g, len(g)), ty + np.tile(g, len(g))])
        xy = np.vstack([near, far])
        z = dem.ground(xy[:, 0], xy[:, 1]) + 2.0
        ok = np.isfinite(z)
        xy, z = xy[ok], z[ok]
        is_near = np.arange(len(ok))[ok] < len(near)
        rec = {"photo": key, "centres": int(len(xy)), "near_truth_centres": int(is_near.sum())}
        for name, near_m in (("near", a.near_m), ("far300", 300.0)):
            elevation = render_horizons(terrain, np.column_stack([xy, z]), bin_deg=1.0, near_m=near_m)
            horizons = Horizons(np.column_stack([xy, z]), elevation, 1.0)
            poses, cost = horizon_poses(horizons, ext.skyline, weights, K, dem, 2.0, search)
            d = np.hypot(poses[:, 0] - tx, poses[:, 1] - ty)
            within = np.flatnonzero(d <= 250.0)
            rec[name] = {"poses": int(len(poses)), "rank_within_250m": int(within[0]) + 1 if len(within) else None,
                         "best_cost": float(cost[0]) if len(cost) else None,
                         "cost_within_250m": float(cost[within[0]]) if len(within) else None}
        rows.append(rec)
        print(key, {k: v for k, v in rec.items() if k != "photo"}, flush=True)
    json.dump(rows, open(a.out, "w"), indent=1)


if __name__ == "__main__":
    main()
