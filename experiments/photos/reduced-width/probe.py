"""Every photo of a side up-scaled 4x (11-13 MP): the hybrid on a reduced copy of each width given (px).

Usage: NUMPY_MADVISE_HUGEPAGE=0 python experiments/photos/reduced-width/probe.py SIDE 1600,1024 OUT.json
(the dev side chooses; ``dev.json`` was made before ``reduced_width`` existed, with ``work_width`` = the width).
"""

import json
import sys
import time

import cv2
import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import extract_skyline, load_photo
from skyrender.features.skyline import SkylineParams


def main() -> None:
    side, widths, out = sys.argv[1], [int(w) for w in sys.argv[2].split(",")], sys.argv[3]
    rows = []
    for it in items_on_side(side):
        image = load_photo(it.image_path)
        truth = it.truth_skyline()
        big = cv2.resize(image, (image.shape[1] * 4, image.shape[0] * 4), interpolation=cv2.INTER_CUBIC)
        row = {"photo": it.key}
        for w in widths:
            t = time.perf_counter()
            r = extract_skyline(big, SkylineParams(method="hybrid", reduced_width=w))
            s = time.perf_counter() - t
            e = column_errors(r.skyline, np.repeat(truth, 4) * 4) / 4
            row[w] = {"median": float(np.median(e)), "within5": float(np.mean(e <= 5)), "seconds": s}
        rows.append(row)
        print(it.key, " ".join(f"{w}: {row[w]['within5'] * 100:5.1f}% {row[w]['median']:.2f}px "
                               f"{row[w]['seconds']:.2f}s" for w in widths), flush=True)
    for w in widths:
        wi = np.array([r[w]["within5"] for r in rows])
        md = np.array([r[w]["median"] for r in rows])
        print(f"{w}: met {np.sum((md <= 2) & (wi >= 0.95))}/{len(rows)}, mean within 5 px {wi.mean() * 100:.1f} %, "
              f"seconds median {np.median([r[w]['seconds'] for r in rows]):.2f}")
    with open(out, "w") as f:
        json.dump(rows, f)


if __name__ == "__main__":
    main()
