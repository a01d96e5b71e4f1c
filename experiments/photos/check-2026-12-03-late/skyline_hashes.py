"""Every validation and held-out photo extracted by ``hybrid`` (the photo preset's extractor) and ``gmm``:
per photo and method a hash of the skyline and confidence bytes, the median error and the share within 5 px.
Run it with the code before a change (``PYTHONPATH=<worktree>``) and with the change, and compare the files.

``python experiments/photos/check-2026-12-03-late/skyline_hashes.py OUT.json``
"""

from __future__ import annotations

import hashlib
import json
import sys

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.features import SkylineParams, extract_skyline, load_photo


def main(out: str) -> None:
    rows = {}
    for side in ("validation", "heldout"):
        for it in items_on_side(side):
            image, truth = load_photo(it.image_path), it.truth_skyline()
            for method in ("hybrid", "gmm"):
                r = extract_skyline(image, SkylineParams(method=method))
                e = column_errors(r.skyline, truth)
                rows[f"{it.key} {method}"] = {
                    "side": side, "hash": hashlib.sha1(r.skyline.tobytes() + r.confidence.tobytes()).hexdigest(),
                    "median": float(np.median(e)), "within5": float(np.mean(e <= 5))}
            print(it.key, flush=True)
    with open(out, "w") as f:
        json.dump({"commit": git_commit(), "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1])
