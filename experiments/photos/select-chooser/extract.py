"""Step 1 of the chooser probe: every training-side photo (train and dev; never validation) extracted by ``hybrid``
and ``gmm`` on ``select``'s EM budget (so that the two are the lines ``select`` chooses between, to the bit), with
their column confidences and the truth, one ``.npz`` a photo (``choose.py`` reads them).

``python experiments/photos/select-chooser/extract.py CACHE_DIR``
"""

from __future__ import annotations

import os
import sys

import numpy as np

from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo
from skyrender.features.skyline import SELECT_MIXTURE_BUDGET


def main(cache: str) -> None:
    os.makedirs(cache, exist_ok=True)
    tol, samples = SELECT_MIXTURE_BUDGET
    for side in ("dev", "train"):
        for it in items_on_side(side):
            path = os.path.join(cache, it.key.replace("/", "__") + ".npz")
            if os.path.exists(path):
                continue
            image = load_photo(it.image_path)
            out = {"truth": it.truth_skyline(), "side": side, "key": it.key, "height": image.shape[0]}
            for method in ("hybrid", "gmm", "select"):
                r = extract_skyline(image, SkylineParams(method=method, mixture_tol=tol, mixture_samples=samples))
                out[method], out[method + "_conf"], out[method + "_p"] = r.skyline, r.confidence, r.sky_probability
            np.savez_compressed(path, **out)
            print(it.key, flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
