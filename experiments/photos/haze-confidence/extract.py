"""Cache the photo extractor's (``select``) line, column confidence and the hybrid's network probability
for the training-side photos (train + dev; never validation), for the haze-cue probe (``probe.py``).

``python experiments/photos/haze-confidence/extract.py --out /tmp/haze-cache``
"""
import argparse
import os

import numpy as np

from skyrender.datasets.real_photos import items_on_side
from skyrender.features.photo_io import load_photo
from skyrender.features.skyline import SkylineParams, extract_skyline

parser = argparse.ArgumentParser()
parser.add_argument("--out", required=True)
parser.add_argument("--sides", nargs="+", default=["train", "dev"])
args = parser.parse_args()
os.makedirs(args.out, exist_ok=True)
for side in args.sides:
    for it in items_on_side(side):
        path = os.path.join(args.out, it.key.replace("/", "__") + ".npz")
        if os.path.exists(path):
            continue
        image = load_photo(it.image_path)
        e = extract_skyline(image, SkylineParams(method="select"))
        np.savez_compressed(path, skyline=e.skyline, confidence=e.confidence, truth=it.truth_skyline(),
                            side=side, key=it.key)
        print(it.key, flush=True)
