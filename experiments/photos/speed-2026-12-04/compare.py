"""Compare two files of ``skyline_hashes.py``: identical hashes, and seconds per method (median, and on
photos 1024 px wide), before / after.

``python experiments/photos/speed-2026-12-04/compare.py BEFORE.json AFTER.json``
"""

from __future__ import annotations

import json
import sys

import numpy as np


def main(before: str, after: str) -> None:
    a, b = (json.load(open(p))["rows"] for p in (before, after))
    keys = sorted(set(a) & set(b))
    same = [k for k in keys if a[k]["hash"] == b[k]["hash"]]
    print(f"{len(same)} of {len(keys)} skylines and confidences identical to the byte")
    for k in keys:
        if a[k]["hash"] != b[k]["hash"]:
            print(f"  differs: {k}: median {a[k]['median']:.2f} -> {b[k]['median']:.2f} px, "
                  f"within 5 px {a[k]['within5']:.1%} -> {b[k]['within5']:.1%}")
    for method in sorted({k.split()[-1] for k in keys}):
        for label, pick in (("all", lambda r: True), ("1024 wide", lambda r: r["shape"][1] == 1024)):
            ks = [k for k in keys if k.endswith(" " + method) and pick(a[k])]
            if ks:
                sa, sb = (np.median([r[k]["seconds"] for k in ks]) for r in (a, b))
                print(f"{method:7s} {label:10s} ({len(ks):3d}): median {sa:.3f} s -> {sb:.3f} s ({sa / sb:.2f}x)")


if __name__ == "__main__":
    main(*sys.argv[1:3])
