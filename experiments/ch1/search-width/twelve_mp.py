"""CH1 photos scaled up 4x (4096 wide, ~11 MP), localized with the photo preset, fov known: searched on the skyline
reduced to 1,024 columns (``search_width``, the preset) and at the photo's own width (``search_width=None``, the preset
before), in the same run; and (not with ``--scaled-only``) the photo as it is (1,024 wide: the same either way).
``python experiments/ch1/search-width/twelve_mp.py [--scaled-only] KEY [KEY ...]`` from the repository root
→ ``twelve_mp.txt``, ``twelve_mp_dev.txt``."""

import math
import sys
import time
from dataclasses import replace

from skyrender.benchmarks.real_localize import photo_scaled_up, with_place
from skyrender.datasets.real_photos import items_on_side
from skyrender.localizer import LocalizeParams, localize
from skyrender.localizer.result import peak_rss_mb


def main(keys: list[str], scaled_only: bool = False) -> None:
    items = [it for side in ("train", "dev", "validation") for it in items_on_side(side) if it.key in keys]
    for _, it, (dem, terrain, model) in with_place(items):
        img, big, fov = photo_scaled_up(it, 4)
        tx, ty = dem.from_lonlat(it.lon, it.lat)
        photo = LocalizeParams.for_photos()
        for name, image, params in (("x4, reduced to 1,024 columns (preset)", big, photo),
                                    ("x4, at its own width (before)", big, replace(photo, search_width=None)),
                                    ("as it is, 1,024 wide", img, photo))[: 2 if scaled_only else 3]:
            t = time.perf_counter()
            r = localize(image, model, 2.0, fov, terrain=terrain, params=replace(params, min_confidence=0.0))
            err = math.hypot(r.pose[0] - tx, r.pose[1] - ty)
            stages = ", ".join(f"{k} {v:.1f}" for k, v in r.stats.seconds.items() if v >= 0.05)
            print(f"{it.key} {image.shape[1]}x{image.shape[0]}: {name}: {time.perf_counter() - t:.1f} s ({stages}), "
                  f"error {err:.0f} m, confidence {r.confidence:.2f}, fov {r.fov:.2f} (given {fov:.2f}), "
                  f"peak RSS {peak_rss_mb():.0f} MB", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main([a for a in args if a != "--scaled-only"], "--scaled-only" in args)
