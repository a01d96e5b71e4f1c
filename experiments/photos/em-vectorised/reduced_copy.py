"""``select`` at a photo's own width against copies reduced to each WIDTH (the boundary then refined at
full resolution, as 12-MP photos are), on one side's photos.

``python experiments/photos/em-vectorised/reduced_copy.py SIDE WIDTH ...`` (2026-12-04: ``dev 640 512``)."""

import sys
import time

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo


def main(side: str, widths: list[int]) -> None:
    variants = {"native": SkylineParams(method="select")}
    for w in widths:
        variants[f"w{w}"] = SkylineParams(method="select", work_width=w - 1, reduced_width=w)
    scores = {k: [] for k in variants}
    seconds = {k: [] for k in variants}
    for it in items_on_side(side):
        image, truth = load_photo(it.image_path), it.truth_skyline()
        for name, params in variants.items():
            t = time.perf_counter()
            extracted = extract_skyline(image, params)
            seconds[name].append(time.perf_counter() - t)
            e = column_errors(extracted.skyline, truth)
            scores[name].append((float(np.mean(e <= 5)), bool(meets_target(np.median(e), np.mean(e <= 5)))))
    for name, rows in scores.items():
        within = [a for a, _ in rows]
        print(f"{side} {name:7s} met {sum(m for _, m in rows)}/{len(rows)} mean within 5 px {100 * np.mean(within):.1f} % "
              f"lowest {100 * min(within):.1f} % median s {np.median(seconds[name]):.2f}")


if __name__ == "__main__":
    main(sys.argv[1], [int(w) for w in sys.argv[2:]])
