"""Every k-means start the skyline extractor makes, ours (skyrender.features.kmeans) beside scikit-learn's
KMeans(n_init=1) on the same samples: are the labels the same, and the skylines (method select)?

    python experiments/photos/kmeans-own/same_labels.py [--photos N] > experiments/photos/kmeans-own/same_labels.txt
"""

import argparse
import os
import sys
import time

import numpy as np
from sklearn.cluster import KMeans
from threadpoolctl import threadpool_limits

import skyrender.features.kmeans as kmeans
from skyrender.datasets.real_photos import photo_items
from skyrender.features.photo_io import load_photo
from skyrender.features.skyline import SkylineParams, extract_skyline

ours_labels = kmeans.kmeans_labels
fits = {"n": 0, "differ": 0, "ours_s": 0.0, "sklearn_s": 0.0}
use = {"which": "ours"}


def both(x, n, seed):
    with threadpool_limits(1):
        t = time.perf_counter()
        a = ours_labels(x, n, seed)
        fits["ours_s"] += time.perf_counter() - t
        t = time.perf_counter()
        b = KMeans(n_clusters=n, n_init=1, random_state=seed).fit(x).labels_
        fits["sklearn_s"] += time.perf_counter() - t
    fits["n"] += 1
    fits["differ"] += int(not np.array_equal(a, b))
    return a if use["which"] == "ours" else b


def main():
    import warnings
    warnings.simplefilter("ignore")
    ap = argparse.ArgumentParser()
    ap.add_argument("--photos", type=int, default=0, help="the first N photos of each set (0: all)")
    args = ap.parse_args()
    kmeans.kmeans_labels = both
    sets = {}
    for item in photo_items():
        sets.setdefault(item.key.split("/")[0], []).append(item)
    same = total = 0
    for name, items in sets.items():
        for item in items[: args.photos or None]:
            image = load_photo(item.image_path)
            image = image[0] if isinstance(image, tuple) else image
            lines = {}
            for which in ("ours", "sklearn"):
                use["which"] = which
                lines[which] = extract_skyline(image, SkylineParams(method="select")).skyline
            equal = np.array_equal(lines["ours"], lines["sklearn"], equal_nan=True)
            same += equal
            total += 1
            if not equal:
                print(f"{item.key}: skylines differ in "
                      f"{int((~np.isclose(lines['ours'], lines['sklearn'], rtol=0, atol=0, equal_nan=True)).sum())} columns")
    print(f"photos: {same} of {total} skylines identical to the bit (method select)")
    print(f"k-means fits: {fits['n']}, labels differing from scikit-learn's: {fits['differ']}; "
          f"seconds ours {fits['ours_s']:.2f}, scikit-learn {fits['sklearn_s']:.2f} (one thread each)")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
