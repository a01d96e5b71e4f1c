"""``select`` as shipped and with SkylineParams fields set, on the training side (dev and train; never validation):
each photo extracted by every variant in turn (the order rotating from photo to photo, so that the machine's drift
falls on all alike), the target (median <= 2 px and >= 95 % within 5 px), the mean share within 5 px, the lowest photo
and the median seconds.

``python experiments/photos/variants_probe.py --variant NAME '{"field": value, ...}' [--variant ...] [--sides dev train]
[--out OUT.json]``, e.g. (``speed-2026-12-07/``) ``--variant "rounds 2" '{"rounds": 2}' --variant "components 4"
'{"components": 4}' --variant "rounds 2, components 4" '{"rounds": 2, "components": 4}'``
"""
import argparse
import json
import time
from dataclasses import replace

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo

SHIPPED = SkylineParams(method="select")
parser = argparse.ArgumentParser()
parser.add_argument("--sides", nargs="+", default=["dev", "train"])
parser.add_argument("--out", default=None)
parser.add_argument("--variant", nargs=2, action="append", default=[], metavar=("NAME", "JSON"),
                    help="a variant: its name and the SkylineParams fields it sets, as a JSON object")
args = parser.parse_args()
VARIANTS = {"shipped": SHIPPED, **{name: replace(SHIPPED, **json.loads(fields)) for name, fields in args.variant}}
rows = []
names = list(VARIANTS)
for side in args.sides:
    for i, it in enumerate(items_on_side(side)):
        image, truth = load_photo(it.image_path), it.truth_skyline()
        row = {"photo": it.key, "side": side}
        for name in names[i % len(names):] + names[:i % len(names)]:
            t = time.perf_counter()
            sky = extract_skyline(image, VARIANTS[name]).skyline
            seconds = time.perf_counter() - t
            e = column_errors(sky, truth)
            row[name] = {"within5": float(np.mean(e <= 5)), "median": float(np.median(e)), "seconds": seconds}
        rows.append(row)
        print(it.key, " ".join(f"{n}: {row[n]['within5']:.3f}" for n in names), flush=True)
for side in args.sides:
    on = [r for r in rows if r["side"] == side]
    print(f"{side} ({len(on)} photos)")
    for n in names:
        w = np.array([r[n]["within5"] for r in on])
        met = sum(r[n]["median"] <= 2 and r[n]["within5"] >= 0.95 for r in on)
        s = np.median([r[n]["seconds"] for r in on])
        ratio = np.median([r[n]["seconds"] / r["shipped"]["seconds"] for r in on])
        print(f"  {n:24s} met {met:3d}  mean within 5 px {100 * w.mean():.1f}%  lowest {100 * w.min():.1f}%  "
              f"median s {s:.3f}  (x{ratio:.2f} of shipped, median of per-photo ratios)")
if args.out:
    with open(args.out, "w") as f:
        json.dump(rows, f)
