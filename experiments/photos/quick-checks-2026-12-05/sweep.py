"""``select`` with extractor settings overridden, on whole sides of the split (a probe, 2026-12-05).

``python experiments/photos/quick-checks-2026-12-05/sweep.py SIDES JSON [JSON ...]``, e.g.
``... dev,train '{"edge_bonus": 24}' '{"work_width": 769, "reduced_width": 768}'``: per side and set of overrides
(``SkylineParams`` fields), the photos meeting the target, the mean share of columns within 5 px and the photos
below 60 %.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import extract_skyline, load_photo
from skyrender.features.skyline import SkylineParams


def main(sides: list[str], overrides: list[dict]) -> None:
    for side in sides:
        photos = [(load_photo(it.image_path), it.truth_skyline()) for it in items_on_side(side)]
        for extra in overrides:
            within5, met = [], 0
            for image, truth in photos:
                e = column_errors(extract_skyline(image, SkylineParams(method="select", **extra)).skyline, truth)
                met += meets_target(np.median(e), np.mean(e <= 5))
                within5.append(np.mean(e <= 5))
            print(f"{side} {json.dumps(extra)}: target met {met} of {len(photos)}, mean within 5 px "
                  f"{np.mean(within5) * 100:.2f} %, below 60 %: {sum(w < 0.6 for w in within5)}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1].split(","), [json.loads(a) for a in sys.argv[2:]])
