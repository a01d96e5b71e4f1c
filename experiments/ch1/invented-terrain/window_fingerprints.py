"""Load the 16 DEM windows ``make bench-real`` cuts around the CH1 places and print their fingerprints, void and
invented counts and load seconds: run before and after a change of DEM loading to show the windows unchanged
(2026-12-05). ``python experiments/ch1/invented-terrain/window_fingerprints.py`` from the repository root."""

import glob
import time

from skyrender.dem import load_dem

TILES = sorted(glob.glob("../shared/data/dem/N4*.hgt"))
WINDOWS = [(6.4, 45.7, 7.8, 46.9), (6.8, 46.3, 8.2, 47.5), (7.1, 46.0, 8.5, 47.2), (7.2, 46.0, 8.6, 47.2),
           (7.3, 45.9, 8.7, 47.1), (7.3, 46.0, 8.7, 47.2), (7.7, 46.4, 9.1, 47.6), (7.8, 46.4, 9.2, 47.6),
           (7.9, 46.4, 9.3, 47.6), (8.1, 46.6, 9.5, 47.8), (8.3, 45.6, 9.7, 46.8), (8.5, 45.9, 9.9, 47.1),
           (8.8, 46.2, 10.2, 47.4), (9.1, 45.8, 10.5, 47.0), (9.1, 45.9, 10.5, 47.1), (9.1, 46.3, 10.5, 47.5)]

for window in WINDOWS:
    start = time.perf_counter()
    dem = load_dem(TILES, bounds=window)
    share = dem.repair.invented / dem.elevation.size
    print(window, f"{time.perf_counter() - start:.1f} s", dem.fingerprint(), dem.repair.voids_filled,
          f"invented {share:.4f}", flush=True)
