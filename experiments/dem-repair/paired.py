"""The DEM load before and after session 34's change to the void fill, timed in turns in one process.

``python experiments/dem-repair/paired.py [ROUNDS]``: loads (a) the CH1 place window around dsc03118 (46.205 N,
9.019 E: the SRTM3 mosaic within 1.2 x 1.4 deg, which reaches into the missing N45E008 / N45E009 tiles) and (b) the
Glarus 1" GeoTIFF (no data outside the canton's outline), each with ``repair_elevation`` as it was (the grid filled
twice: once to find the spikes, once without them) and as it is (filled once; spikes 3 or more cells from every void
refilled on a window of their own), in turns, and checks that both give the same elevations to the bit.
"""
import sys
import time

import numpy as np

from skyrender.benchmarks.real_localize import place_dem
from skyrender.dem import io as dem_io
from skyrender.dem import load_dem, repair
from skyrender.dem.grid import RepairReport

SHIPPED = repair.repair_elevation


def before(z, cell_size_m, nodata_mask=None):
    """repair_elevation as it was at 30afcfb: the same steps, the fill done twice."""
    z = np.asarray(z, dtype=np.float64)
    void = ~np.isfinite(z)
    if nodata_mask is not None:
        void |= nodata_mask
    implausible = ~void & ((z < repair.PLAUSIBLE_RANGE_M[0]) | (z > repair.PLAUSIBLE_RANGE_M[1]))
    valid = ~void & ~implausible
    spikes = repair.find_spikes(np.where(valid, z, 0.0), cell_size_m, valid)
    bad_spikes = implausible | spikes
    fixed, far = repair._fill(np.where(valid & ~spikes, z, 0.0), valid & ~spikes)
    far_cells = 0 if far is None else int(np.count_nonzero(far))
    return fixed, RepairReport(int(void.sum()), int(bad_spikes.sum()), (), far_cells), far if far_cells else None


def load(which):
    if which == "ch1-window":
        return place_dem(46.205002, 9.0194998)[0]
    return load_dem("../shared/data/dem/srtm1_glarus_1arc.tif")


rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 3  # 0: define the functions only (all_tiles.py)
for which in ("ch1-window", "glarus-1arcsec") if rounds else ():
    seconds = {"before": [], "now": []}
    out = {}
    for r in range(rounds):
        for name, fn in (("before", before), ("now", SHIPPED)) if r % 2 == 0 else (("now", SHIPPED), ("before", before)):
            dem_io.repair_elevation = fn
            t = time.perf_counter()
            dem = load(which)
            seconds[name].append(time.perf_counter() - t)
            out[name] = dem.elevation
    dem_io.repair_elevation = SHIPPED
    same = np.array_equal(out["before"], out["now"], equal_nan=True)
    b, n = np.median(seconds["before"]), np.median(seconds["now"])
    print(f"{which}: load before {b:.2f} s, now {n:.2f} s (medians of {rounds}), {n / b:.2f}x; "
          f"the same elevations to the bit: {same}; spikes repaired {dem.repair.spikes_repaired}, "
          f"voids filled {dem.repair.voids_filled}", flush=True)
