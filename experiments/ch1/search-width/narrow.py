"""The other way: CH1 photos reduced to 512 px wide, localized with the photo preset (fov known, no abstention) at
their own width (as the preset does) and on their skyline enlarged to 1,024 columns (``reduce_skyline`` the other
way), in the same run. ``python experiments/ch1/search-width/narrow.py KEY [KEY ...]`` from the repository root
→ ``narrow.txt``."""

import math
import sys
import time
from dataclasses import replace

import cv2
import numpy as np

from skyrender.benchmarks.real_localize import with_place
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import extract_skyline, load_photo
from skyrender.features.skyline import ExtractedSkyline
from skyrender.localizer import LocalizeParams, localize
from skyrender.localizer.pipeline import reduce_skyline


def main(keys: list[str]) -> None:
    items = [it for side in ("train", "dev") for it in items_on_side(side) if it.key in keys]
    photo = replace(LocalizeParams.for_photos(), min_confidence=0.0)
    for _, it, (dem, terrain, model) in with_place(items):
        img = load_photo(it.image_path)
        small = cv2.resize(img, (512, int(round(img.shape[0] * 512 / img.shape[1]))), interpolation=cv2.INTER_AREA)
        fov = math.degrees(2 * math.atan(img.shape[1] / (2 * it.focal_px)))
        tx, ty = dem.from_lonlat(it.lon, it.lat)
        ex = extract_skyline(small, photo.skyline_params())
        H, W = small.shape[:2]
        rows, conf, W2, H2 = reduce_skyline(ex.skyline, ex.confidence, W, H, 1024)
        enlarged = ExtractedSkyline(rows, conf, None)
        for name, image, sky in (("512 at its own width", small, ex),
                                 ("512 enlarged to 1,024 columns", np.zeros((H2, W2, 3), np.uint8), enlarged)):
            t = time.perf_counter()
            r = localize(image, model, 2.0, fov, terrain=terrain, skyline=sky, params=photo)
            err = math.hypot(r.pose[0] - tx, r.pose[1] - ty)
            print(f"{it.key} {name}: {time.perf_counter() - t:.1f} s, error {err:.0f} m, confidence {r.confidence:.2f}",
                  flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
