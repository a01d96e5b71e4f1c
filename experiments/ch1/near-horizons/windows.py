"""Smaller windows of the skyline for the near-skyline photos? (a probe on robust_costs.py's cached horizons, 2026-12-05)

``python experiments/ch1/near-horizons/windows.py CACHE_DIR [N_RANDOM]``

For every photo whose horizons (from 300 m; the near-truth grid and the random centres) ``robust_costs.py`` has
cached, the photo preset's far-horizon matching (``horizon_poses``) with its windows and with thirds and quarters
added: the rank by cost of the first pose within 250 m of the truth.
"""

from __future__ import annotations

import glob
import os
import sys
from dataclasses import replace

import numpy as np

from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.dem import load_dem
from skyrender.diagnostics.oracle import DEM_DIR, tiles_around
from skyrender.features import extract_skyline, load_photo
from skyrender.localizer import LocalizeParams
from skyrender.localizer.horizon_search import WINDOWS, horizon_poses
from skyrender.localizer.pipeline import column_weights
from skyrender.model.horizons import Horizons

THIRDS = ((0.0, 1 / 3), (1 / 3, 2 / 3), (2 / 3, 1.0))
QUARTERS = ((0.0, 0.25), (0.25, 0.5), (0.5, 0.75), (0.75, 1.0))


def main(cache: str, n_random: str = "20000") -> None:
    items = {it.key: it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")}
    params = LocalizeParams.for_photos()
    for path in sorted(glob.glob(os.path.join(cache, f"*-{n_random}.npz"))):
        key = os.path.basename(path)[: -len(f"-{n_random}.npz")].replace("__", "/")
        it = items[key]
        z = np.load(path)
        xy, P = z["xy"], z["elevation"].astype(np.float32)
        dem = load_dem(tiles_around(it.lat, it.lon, DEM_DIR), bounds=(it.lon - 0.1, it.lat - 0.1, it.lon + 0.1, it.lat + 0.1))
        tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
        image = load_photo(it.image_path)
        H, W = image.shape[:2]
        ext = extract_skyline(image, params.skyline_params())
        K = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
        horizons = Horizons(np.column_stack([xy, np.zeros(len(xy))]), P, 1.0)
        ranks = {}
        for name, windows in (("preset", WINDOWS), ("+thirds", WINDOWS + THIRDS), ("+quarters", WINDOWS + QUARTERS),
                              ("thirds+quarters", WINDOWS + THIRDS + QUARTERS)):
            search = replace(params.horizon, per_window=5000, windows=windows)
            poses, _ = horizon_poses(horizons, ext.skyline, column_weights(ext.confidence), K, dem, 2.0, search)
            within = np.flatnonzero(np.hypot(poses[:, 0] - tx, poses[:, 1] - ty) <= 250.0)
            ranks[name] = int(within[0]) + 1 if len(within) else None
        print(key, ranks, flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])
