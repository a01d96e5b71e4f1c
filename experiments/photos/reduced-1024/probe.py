"""A photo about 1,024 px wide extracted on a reduced copy (``select``), the boundary refined at full resolution.

Usage: python experiments/photos/reduced-1024/probe.py SIDE 0,768,640 OUT.json

Issue 18's speed goal is 0.5 s for a 1,024-wide photo; ``select`` takes 0.82 s (``make bench-skyline``). Photos wider
than ``SkylineParams.work_width`` (1,600) are already extracted on a copy ``reduced_width`` wide and refined in a band
around the scaled-up boundary (on 4x up-scaled dev photos at 1,024 as well as at 1,600). Here every photo of a side,
as it is, with ``work_width = reduced_width`` = each width given (0: as shipped, no reduced copy). The dev side
chooses (rule in README.md, set before the run); the validation side is run once, for the chosen width only.
"""

import json
import sys
import time

import numpy as np

from skyrender.benchmarks.skyline_photos import TARGET_MEDIAN_PX, TARGET_WITHIN5, column_errors
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.features import extract_skyline, load_photo
from skyrender.features.skyline import SkylineParams


def params_for(width: int) -> SkylineParams:
    return SkylineParams(method="select") if width == 0 else SkylineParams(method="select", work_width=width,
                                                                           reduced_width=width)


def main() -> None:
    side, widths, out = sys.argv[1], [int(w) for w in sys.argv[2].split(",")], sys.argv[3]
    rows = []
    print(f"commit {git_commit()}; {side} side; select on each photo as it is (0) and on a copy each width wide")
    extract_skyline(load_photo(items_on_side(side)[0].image_path), params_for(0))  # warm: the network loaded once
    for it in items_on_side(side):
        image = load_photo(it.image_path)
        truth = it.truth_skyline()
        row = {"photo": it.key, "width": image.shape[1]}
        for w in widths:
            t = time.perf_counter()
            r = extract_skyline(image, params_for(w))
            s = time.perf_counter() - t
            e = column_errors(r.skyline, truth)
            row[str(w)] = {"median": float(np.median(e)), "within5": float(np.mean(e <= 5)), "seconds": s}
        rows.append(row)
        print(f"{it.key:34s} {row['width']:5d} " + " ".join(
            f"{w}: {row[str(w)]['within5'] * 100:5.1f}% {row[str(w)]['median']:.2f}px {row[str(w)]['seconds']:.2f}s"
            for w in widths), flush=True)
    summary = {}
    for w in widths:
        wi = np.array([r[str(w)]["within5"] for r in rows])
        md = np.array([r[str(w)]["median"] for r in rows])
        sec = np.array([r[str(w)]["seconds"] for r in rows])
        summary[str(w)] = {"met": int(np.sum((md <= TARGET_MEDIAN_PX) & (wi >= TARGET_WITHIN5))), "photos": len(rows),
                           "mean_within5": float(wi.mean()), "min_within5": float(wi.min()),
                           "median_seconds": float(np.median(sec))}
        s = summary[str(w)]
        print(f"{w}: met {s['met']}/{s['photos']}, mean within 5 px {100 * s['mean_within5']:.1f} %, lowest "
              f"{100 * s['min_within5']:.1f} %, median {s['median_seconds']:.2f} s")
    with open(out, "w") as f:
        json.dump({"commit": git_commit(), "side": side, "summary": summary, "photos": rows}, f, indent=1)


if __name__ == "__main__":
    main()
