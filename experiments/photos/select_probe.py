"""``select`` on every photo of a side, as shipped (0) and with SkylineParams fields set to each value given.

Usage: python experiments/photos/select_probe.py SIDE FIELDS VALUES OUT.json
e.g. ``dev work_width,reduced_width 0,768,640,512`` (``reduced-1024/``: a photo about 1,024 px wide extracted on a
copy that wide), ``dev select_gmm_width 0,768,640,512`` at 94dd519 (``select-gmm-reduced/``: only select's gmm line
on such a copy, an option since removed).
Per photo and width: the share of columns within 5 px, the median error and the seconds; then the summary
against the target. The dev side chooses; the validation side is run once, for the chosen value only.
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


def params_for(fields: list[str], value: int) -> SkylineParams:
    """``select`` with each of ``fields`` set to ``value`` (0: as shipped)."""
    return SkylineParams(method="select", **({f: value for f in fields} if value else {}))


def main() -> None:
    side, fields, out = sys.argv[1], sys.argv[2].split(","), sys.argv[4]
    widths = [int(w) for w in sys.argv[3].split(",")]
    rows = []
    print(f"commit {git_commit()}; {side} side; select as shipped (0) and with {', '.join(fields)} at each value")
    extract_skyline(load_photo(items_on_side(side)[0].image_path), params_for(fields, 0))  # warm: the network loaded once
    for it in items_on_side(side):
        image = load_photo(it.image_path)
        truth = it.truth_skyline()
        row = {"photo": it.key, "width": image.shape[1]}
        for w in widths:
            t = time.perf_counter()
            r = extract_skyline(image, params_for(fields, w))
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
