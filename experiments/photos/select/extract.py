"""Step 1 of the selection probe: every photo of a side extracted by ``hybrid``, ``gmm`` and ``net``, the
skylines, column confidences and truth kept in one ``.npz`` a photo (``choose.py`` reads them).

``python experiments/photos/select/extract.py SIDE CACHE_DIR``   (run 2026-12-04 for dev and train)
"""

from __future__ import annotations

import os
import sys

import numpy as np

from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo


def main(side: str, cache: str) -> None:
    os.makedirs(cache, exist_ok=True)
    for it in items_on_side(side):
        image = load_photo(it.image_path)
        out = {"truth": it.truth_skyline()}
        for method in ("hybrid", "gmm", "net"):
            r = extract_skyline(image, SkylineParams(method=method))
            out[method], out[method + "_conf"] = r.skyline, r.confidence
        np.savez(os.path.join(cache, it.key.replace("/", "__") + ".npz"), **out)
        print(it.key, flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:3])
