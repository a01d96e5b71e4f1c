"""The photo extractor (``select``) with the boundary search in numpy's passes (the previous code, in a worktree) and
compiled (this code), on the same photos, each code in its own process: every skyline and column confidence
compared to the bit, and the seconds per photo (each photo extracted twice, the second timed).

``python experiments/photos/compiled-boundary/ab.py <worktree of the previous code> <this code> [side ...] > ab.txt``
"""

import os
import pickle
import subprocess
import sys
import tempfile
import time

import numpy as np


def extract(sides: list[str], out: str) -> None:
    """In this process (the code on PYTHONPATH): every photo's skyline, confidence and seconds, pickled."""
    from skyrender.datasets.real_photos import items_on_side
    from skyrender.features import extract_skyline, load_photo
    from skyrender.features.skyline import SkylineParams

    params = SkylineParams(method="select")
    rows = {}
    for side in sides:
        for item in items_on_side(side):
            image = load_photo(item.image_path)
            extract_skyline(image, params)  # warm: the network, numba's cache
            start = time.perf_counter()
            found = extract_skyline(image, params)
            rows[item.key] = (found.skyline, found.confidence, time.perf_counter() - start, image.shape[1])
    with open(out, "wb") as f:
        pickle.dump(rows, f)


def main(old: str, new: str, *sides: str) -> None:
    sides = list(sides) or ["dev"]
    results = []
    for code in (old, new):
        out = tempfile.mktemp(suffix=".pkl")
        subprocess.run([sys.executable, __file__, "--one", out, *sides], check=True,
                       env=dict(os.environ, PYTHONPATH=os.path.abspath(code)))
        with open(out, "rb") as f:
            results.append(pickle.load(f))
    before, after = results
    same = sum(np.array_equal(before[k][0], after[k][0], equal_nan=True) and np.array_equal(before[k][1], after[k][1])
               for k in before)
    tb, ta = np.array([before[k][2] for k in before]), np.array([after[k][2] for k in before])
    print(f"{len(before)} photos of {', '.join(sides)} (widths {min(v[3] for v in before.values())}-"
          f"{max(v[3] for v in before.values())} px), select, each extracted twice and the second timed:")
    print(f"  skyline and column confidence the same to the bit: {same} of {len(before)}")
    print(f"  seconds per photo, median: previous {np.median(tb):.3f}, compiled {np.median(ta):.3f} "
          f"(median ratio {np.median(ta / tb):.2f}); total {tb.sum():.1f} -> {ta.sum():.1f} s")


if __name__ == "__main__":
    if sys.argv[1] == "--one":
        extract(sys.argv[3:], sys.argv[2])
    else:
        main(*sys.argv[1:])
