"""Fingerprint, invented-mask hash, repair report and load seconds of 4 CH1 windows, the Glarus 1-arc-second DEM,
N47E011, S44E170 and the 14 N4*.hgt tiles uncut: run before and after a change of void filling to show both the
elevations and the invented masks unchanged (2026-12-05, session 12). From the repository root."""

import glob
import hashlib
import time

import numpy as np

from skyrender.dem import load_dem

TILES = sorted(glob.glob("../shared/data/dem/N4*.hgt"))
WINDOWS = [(7.3, 45.9, 8.7, 47.1), (8.3, 45.6, 9.7, 46.8), (9.1, 45.8, 10.5, 47.0), (7.1, 46.0, 8.5, 47.2)]
FILES = ["../shared/data/dem/srtm1_glarus_1arc.tif", "../shared/data/dem/N47E011.hgt", "../shared/data/dem/S44E170.hgt"]

for source, bounds in [(TILES, b) for b in WINDOWS] + [(f, None) for f in FILES] + [(TILES, None)]:
    start = time.perf_counter()
    dem = load_dem(source, bounds=bounds) if bounds else load_dem(source)
    mask = "none" if dem.invented is None else hashlib.sha1(np.packbits(dem.invented).tobytes()).hexdigest()[:12]
    label = bounds or (source if isinstance(source, str) else "14 tiles")
    print(label, dem.fingerprint(), mask, dem.repair, f"{time.perf_counter() - start:.1f} s", flush=True)
