"""``select`` skylines and confidences of the 31 dev photos and the 60 CH1 validation photos, with
whichever ``skyrender`` is on ``PYTHONPATH``, and the seconds a photo.

``python experiments/photos/em-vectorised/dump.py OUT.npz`` (compare two with ``compare.py``)."""

import sys
import time

import numpy as np

from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo


def main(out: str) -> None:
    items = items_on_side("dev") + [it for it in items_on_side("validation") if it.key.startswith("ch1/")]
    arrays, seconds = {}, []
    for it in items:
        image = load_photo(it.image_path)
        t = time.perf_counter()
        extracted = extract_skyline(image, SkylineParams(method="select"))
        seconds.append(time.perf_counter() - t)
        key = it.key.replace("/", "__")
        arrays[key], arrays[key + "__conf"] = extracted.skyline, extracted.confidence
    np.savez(out, **arrays)
    print(out, len(items), "median s", np.median(seconds), "mean", np.mean(seconds))


if __name__ == "__main__":
    main(sys.argv[1])
