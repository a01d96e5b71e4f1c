"""Where ``select`` took one of hybrid and gmm, is the other better? (a probe, 2026-12-05)

``python experiments/ch1/other-extractor/compare.py > extractors-train-dev.txt``: for every CH1 photo of the training
and dev sides, the share of columns where the hybrid and gmm lines lie more than 5 px apart, which one ``select`` took,
and each one's share of columns within 5 px of the truth.
"""

from __future__ import annotations

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import extract_skyline, load_photo
from skyrender.features.skyline import SkylineParams


def main() -> None:
    for side in ("train", "dev"):
        for it in items_on_side(side):
            if not it.key.startswith("ch1/"):
                continue
            image, truth = load_photo(it.image_path), it.truth_skyline()
            hybrid, gmm, chosen = (extract_skyline(image, SkylineParams(method=m)) for m in ("hybrid", "gmm", "select"))
            H = image.shape[0]
            a, b = (np.where(np.isfinite(x.skyline), x.skyline, H + 1e3) for x in (hybrid, gmm))
            took = "hybrid" if np.array_equal(np.nan_to_num(chosen.skyline), np.nan_to_num(hybrid.skyline)) else "gmm"
            w = {name: float(np.mean(column_errors(x.skyline, truth) <= 5)) * 100
                 for name, x in (("hybrid", hybrid), ("gmm", gmm))}
            print(f"{it.key:34s} apart {np.mean(np.abs(a - b) > 5) * 100:5.1f} %  took {took:6s} "
                  f"hybrid {w['hybrid']:5.1f} gmm {w['gmm']:5.1f}", flush=True)


if __name__ == "__main__":
    main()
