"""select with hazy_ridge_logit's 'brighter than the field' gate at 4 L (shipped) and wider, training side only."""
import json
import sys

import numpy as np

import skyrender.features.sky as sky
from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo

orig = sky.hazy_ridge_logit
def gated(limit):
    def f(features, field, sigma, weight=20.0, blue_weight=None):
        greyer = features[..., 2] - field[..., 2]
        greyer -= max(8.0, 3.0 * sigma)
        greyer /= 6.0
        nb = features[..., 0] - field[..., 0]
        np.subtract(limit, nb, out=nb)
        nb /= limit
        pen = (sky.blue_field_weight(field) if blue_weight is None else blue_weight) * weight
        pen *= np.clip(greyer, 0, 1, out=greyer)
        pen *= np.clip(nb, 0, 1, out=nb)
        return pen
    return f
P = SkylineParams(method="select")
rows = []
for side in ["dev", "train"]:
    for it in items_on_side(side):
        im, truth = load_photo(it.image_path), it.truth_skyline()
        r = {"photo": it.key, "side": side}
        for name, lim in [("shipped", None), ("gate 8", 8.0), ("gate 16", 16.0)]:
            sky.hazy_ridge_logit = orig if lim is None else gated(lim)
            e = column_errors(extract_skyline(im, P).skyline, truth)
            r[name] = (float(np.mean(e <= 5)), float(np.median(e)))
        rows.append(r)
        if r["gate 8"] != r["shipped"] or r["gate 16"] != r["shipped"]:
            print(it.key, {k: round(v[0], 3) for k, v in r.items() if k not in ("photo", "side")}, flush=True)
for side in ["dev", "train"]:
    on = [r for r in rows if r["side"] == side]
    for name in ["shipped", "gate 8", "gate 16"]:
        met = sum(r[name][1] <= 2 and r[name][0] >= 0.95 for r in on)
        print(side, name, met, round(100 * np.mean([r[name][0] for r in on]), 2))
json.dump(rows, open(sys.argv[1], "w"))
