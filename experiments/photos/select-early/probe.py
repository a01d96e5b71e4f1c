"""Can `select` skip the per-photo mixtures (gmm) when the network-led hybrid is sure of itself?

For every photo of the given sides: the hybrid's and gmm's skylines (each as `select` computes them), which one
`select` keeps, each one's per-photo median error and share within 5 px, and statistics of the hybrid's per-column
confidence (mean, 5th percentile, share >= 0.5). Writes one JSON row per photo.

    python experiments/photos/select-early/probe.py train dev --out experiments/photos/select-early/train-dev.json
"""
import argparse
import json
import time

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo
from skyrender.features.skyline import select_skylines

parser = argparse.ArgumentParser()
parser.add_argument("sides", nargs="+")
parser.add_argument("--out", required=True)
args = parser.parse_args()
rows = []
for side in args.sides:
    for it in items_on_side(side):
        image = load_photo(it.image_path)
        truth = it.truth_skyline()
        t = time.perf_counter()
        hybrid = extract_skyline(image, SkylineParams(method="hybrid"))
        t_h = time.perf_counter() - t
        gmm = extract_skyline(image, SkylineParams(method="gmm"))
        chosen = select_skylines(hybrid, gmm)
        row = {"photo": it.key, "side": side, "width": int(image.shape[1]), "hybrid_s": t_h,
               "select_takes": "gmm" if chosen is gmm else "hybrid"}
        for name, r in (("hybrid", hybrid), ("gmm", gmm)):
            e = column_errors(r.skyline, truth)
            row[name] = {"median": float(np.median(e)), "within5": float(np.mean(e <= 5))}
        c = hybrid.confidence
        row["conf_mean"], row["conf_p05"], row["conf_share50"] = float(c.mean()), float(np.percentile(c, 5)), float(np.mean(c >= 0.5))
        H = image.shape[0]
        a, b = (np.where(np.isfinite(s.skyline), s.skyline, H + 1e3) for s in (hybrid, gmm))
        row["apart_share"] = float(np.mean(np.abs(a - b) > 5))
        rows.append(row)
        print(it.key, row["select_takes"], f"h {row['hybrid']['within5']:.3f} g {row['gmm']['within5']:.3f} "
              f"conf mean {row['conf_mean']:.3f} p05 {row['conf_p05']:.3f}", flush=True)
json.dump(rows, open(args.out, "w"), indent=1)
