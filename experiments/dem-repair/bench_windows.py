"""Every CH1 place window of the split (``make bench-real``'s DEMs) loaded with repair_elevation as it was and as it
is: the same elevations to the bit? ``python experiments/dem-repair/bench_windows.py`` (→ bench_windows.txt)."""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
sys.argv = sys.argv[:1] + ["0"]  # paired.py's timing loop: no rounds
from paired import SHIPPED, before  # noqa: E402

from skyrender.benchmarks.real_localize import place_dem, places_of  # noqa: E402
from skyrender.datasets.real_photos import items_on_side  # noqa: E402
from skyrender.dem import io as dem_io  # noqa: E402

same = total = 0
for side in ("train", "dev", "validation"):
    _, centres = places_of([it for it in items_on_side(side) if it.key.startswith("ch1")])
    for place, (lat, lon) in centres.items():
        out, seconds = [], []
        for fn in (before, SHIPPED):
            dem_io.repair_elevation = fn
            t = time.perf_counter()
            out.append(place_dem(lat, lon)[0])
            seconds.append(time.perf_counter() - t)
        dem_io.repair_elevation = SHIPPED
        ok = np.array_equal(out[0].elevation, out[1].elevation, equal_nan=True)
        same, total = same + ok, total + 1
        r = out[1].repair
        print(f"{side} {place}: the same {ok}; voids {r.voids_filled}, spikes {r.spikes_repaired}; "
              f"load {seconds[0]:.1f} -> {seconds[1]:.1f} s", flush=True)
print(f"{same} of {total} place windows the same to the bit")
