"""A CH1 validation photo scaled up 4x (4096 wide, ~11 MP), localized with the photo preset, fov known: the
re-ranking with its stride scaled to the width (the preset), unscaled (every 32nd of 4,096 columns) and off (the
preset before session 13). ``python experiments/ch1/rerank-all/twelve_mp.py ch1/_dsc0022_01024`` from the repository
root (the place's model cached or built) → ``twelve_mp.txt`` (run at d1e86a7; since session 14 the preset searches such
a photo on its skyline reduced to 1,024 columns, so a run now times that: ``../search-width/``)."""

import math
import sys
import time
from dataclasses import replace

from skyrender.benchmarks.real_localize import photo_scaled_up, with_place
from skyrender.datasets.real_photos import items_on_side
from skyrender.localizer import LocalizeParams, localize


def main(key: str) -> None:
    items = [it for it in items_on_side("validation") if it.key == key]
    for _, it, (dem, terrain, model) in with_place(items):
        _, big, fov = photo_scaled_up(it, 4)
        tx, ty = dem.from_lonlat(it.lon, it.lat)
        photo = LocalizeParams.for_photos()
        for name, params in (("scaled stride (preset)", photo), ("stride 32 unscaled", replace(photo, rerank_stride=8)),
                             ("no re-ranking (before)", replace(photo, horizon_rerank=0))):
            t = time.perf_counter()
            r = localize(big, model, 2.0, fov, terrain=terrain, params=replace(params, min_confidence=0.0))
            err = math.hypot(r.pose[0] - tx, r.pose[1] - ty)
            print(f"{key} x4 {big.shape[1]}x{big.shape[0]}: {name}: {time.perf_counter() - t:.1f} s (re-ranking "
                  f"{r.stats.seconds.get('rerank', 0):.1f} s), error {err:.0f} m, confidence {r.confidence:.2f}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
