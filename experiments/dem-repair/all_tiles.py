"""Every DEM file of ../shared/data/dem loaded with repair_elevation as it was (paired.py's ``before``) and as it is:
the same elevations to the bit? ``python experiments/dem-repair/all_tiles.py`` (→ all_tiles.txt)."""
import glob
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
sys.argv = sys.argv[:1] + ["0"]  # paired.py's timing loop: no rounds
from paired import SHIPPED, before  # noqa: E402

from skyrender.dem import io as dem_io  # noqa: E402
from skyrender.dem import load_dem  # noqa: E402

files = sorted(glob.glob("../shared/data/dem/*.hgt")) + sorted(glob.glob("../shared/data/dem/*.tif")) + \
    sorted(glob.glob("../shared/data/dem/*.asc"))
same = 0
for path in files:
    out = []
    for fn in (before, SHIPPED):
        dem_io.repair_elevation = fn
        out.append(load_dem(path))
    dem_io.repair_elevation = SHIPPED
    ok = np.array_equal(out[0].elevation, out[1].elevation, equal_nan=True)
    same += ok
    r = out[1].repair
    print(f"{os.path.basename(path)}: the same {ok}; voids {r.voids_filled}, spikes {r.spikes_repaired}", flush=True)
print(f"{same} of {len(files)} the same to the bit")
