"""For each of the 73 training-side CH1 photos: the rank (0-based) of the best (centre, azimuth) pair within 500 m and
1 km of the true position in the far-horizon search's cost, in the (tilt, window) list where it ranks best, and that
list. A pair ranked below ``per_window`` (200) in some list is among the search's poses.
``python experiments/ch1/in-list/recall.py OUT.json`` from the repository root (the place models cached or built)
→ ``recall-train-dev.json``."""
import json
import sys
import time

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, with_place
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer.horizon_search import horizon_costs, skyline_directions, standable_centres

params = LocalizeParams.for_photos()
hp = params.horizon
rows = []
items = [it for s in ('train', 'dev') for it in items_on_side(s) if it.key.startswith('ch1/')]
for n, it, (dem, terrain, model) in with_place(items):
    t = time.perf_counter()
    image, sky, weights = photo_skyline(it, params)
    H, W = image.shape[:2]
    k = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
    hz = model.horizons
    cidx = standable_centres(hz, dem, params.max_ground_slope_deg)
    cidx = np.arange(len(hz)) if cidx is None else cidx
    spectra = (hz.spectra[0][cidx], hz.spectra[1][cidx])
    tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
    dist = np.hypot(hz.centres[cidx, 0] - tx, hz.centres[cidx, 1] - ty)
    row = {"photo": it.key, "nearest_centre_m": float(dist.min())}
    for R in (500.0, 1000.0):
        near = dist <= R
        best_rank, best_where = None, None
        for tilt in hp.tilts:
            bins, el, w = skyline_directions(sky, weights, k, hz.bin_deg, tilt)
            if len(bins) < hp.min_bins:
                continue
            frac = (bins - bins[0]) / max(bins[-1] - bins[0], 1)
            for wi, (lo, hi) in enumerate(hp.windows):
                ww = w * ((frac >= lo) & (frac <= hi))
                if np.count_nonzero(ww) < hp.min_bins:
                    continue
                cost, _ = horizon_costs(spectra, hz.elevation.shape[1], bins, el, ww, hz.bin_deg, hp.terms, hp.max_swing_deg)
                if not near.any():
                    continue
                cmin = cost[near].min()
                rank = int(np.count_nonzero(cost < cmin))
                if best_rank is None or rank < best_rank:
                    j = np.argmin(cost[near].min(axis=1))
                    b = int(np.argmin(cost[near][j]))
                    best_rank, best_where = rank, (tilt, wi, b * hz.bin_deg, float(dist[near][j]))
        row[f"rank_{R:.0f}"] = best_rank
        row[f"where_{R:.0f}"] = best_where
    row["seconds"] = time.perf_counter() - t
    rows.append(row)
    print(n, it.key, row["nearest_centre_m"], row["rank_500"], row["rank_1000"], row["where_1000"],
          f"{row['seconds']:.1f}s", flush=True)
json.dump(rows, open(sys.argv[1], 'w'), indent=1)
