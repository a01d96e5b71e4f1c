"""Photos of the given sides extracted by the given methods: per photo and method a hash of the
skyline and confidence bytes, the median error, the share within 5 px and the seconds of
``extract_skyline``. Run it with the code before a change (``PYTHONPATH=<worktree>``) and with the
change, one after the other, and compare the files (``compare.py``).

``python experiments/photos/speed-2026-12-04/skyline_hashes.py OUT.json [--sides validation heldout]
[--methods hybrid gmm]``
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.features import SkylineParams, extract_skyline, load_photo


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--sides", nargs="+", default=["validation", "heldout"])
    ap.add_argument("--methods", nargs="+", default=["hybrid", "gmm"])
    args = ap.parse_args()
    rows = {}
    extract_skyline(np.zeros((64, 96, 3), np.uint8) + 128, SkylineParams(method=args.methods[0]))  # imports, network
    for side in args.sides:
        for it in items_on_side(side):
            image, truth = load_photo(it.image_path), it.truth_skyline()
            for method in args.methods:
                t = time.perf_counter()
                r = extract_skyline(image, SkylineParams(method=method))
                seconds = time.perf_counter() - t
                e = column_errors(r.skyline, truth)
                rows[f"{it.key} {method}"] = {
                    "side": side, "shape": list(image.shape[:2]), "seconds": seconds,
                    "hash": hashlib.sha1(r.skyline.tobytes() + r.confidence.tobytes()).hexdigest(),
                    "median": float(np.median(e)), "within5": float(np.mean(e <= 5))}
            print(it.key, flush=True)
    with open(args.out, "w") as f:
        json.dump({"commit": git_commit(), "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
