"""Oracle fits at the true positions with a tree canopy added below the treeline (a probe, experiments/ch1/canopy/).

``python experiments/ch1/canopy/probe.py SIDE N CANOPIES HEIGHT_RANGE``: N CH1 photos of SIDE (spread as the oracle's
``--limit``), each canopy height (m, comma-separated) added to every DEM cell below 1,700 m, tapering to 0 at 2,000 m,
the camera height held within HEIGHT_RANGE m of 2 m (the localizer holds it at 2 m).
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.diagnostics import oracle
from skyrender.features import load_photo
from skyrender.render import Terrain


def with_canopy(dem, canopy_m: float, top_m: float = 2000.0, ramp_m: float = 300.0):
    """The DEM with ``canopy_m`` added below ``top_m - ramp_m``, tapering linearly to nothing at ``top_m``."""
    z = dem.elevation
    return dataclasses.replace(dem, elevation=z + canopy_m * np.clip((top_m - z) / ramp_m, 0, 1))


def main() -> None:
    side, n, canopies, height_range = sys.argv[1], int(sys.argv[2]), sys.argv[3], float(sys.argv[4])
    items = [it for it in items_on_side(side) if it.key.startswith("ch1/")]
    items = items[:: max(1, len(items) // n)][:n]
    canopies = [float(v) for v in canopies.split(",")]
    medians = {c: [] for c in canopies}
    for it in items:
        image = load_photo(it.image_path)
        H, W = image.shape[:2]
        dem = oracle.dem_around(it.lat, it.lon, 60.0)
        x, y = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
        line = f"{it.key:34s} ground {dem.ground(x, y):6.0f} m"
        for c in canopies:
            fit = oracle.oracle_fit(Terrain(with_canopy(dem, c) if c else dem), x, y, it.truth_skyline(),
                                    Intrinsics(W, H, it.focal_px, W / 2, H / 2), height_range=height_range)
            s = oracle.summarise(fit)
            medians[c].append(s["median_px"])
            bins = " ".join(f"{k}:{v['median_px']:.1f}" for k, v in s["by_distance"].items())
            line += f" | c={c:.0f}: {s['median_px']:5.2f} px w5 {100 * s['within5']:4.1f}% h {s['height']:5.1f} {bins}"
        print(line, flush=True)
    for c in canopies:
        print(f"canopy {c:.0f} m: median over photos {np.median(medians[c]):.2f} px, mean {np.mean(medians[c]):.2f}")


if __name__ == "__main__":
    main()
