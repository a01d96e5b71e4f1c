"""Recall of the far-horizon poses: the shipped search against one pose per cell (distinct-cells.patch applied).

    python experiments/ch1/distinct-cells/recall.py train,dev 1000/8 2000/8

Per photo and variant (cell metres / pool): poses, the nearest pose to the truth, poses within 1 km, distinct 2 km
cells among the poses, seconds; written to /tmp/prof/recall.json (committed as recall-train-dev.json).
"""
import json
import os
import sys
import time
from dataclasses import replace

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, with_place
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer.horizon_search import horizon_poses, standable_centres

params = LocalizeParams.for_photos()
variants = {"shipped": params.horizon}
for spec in sys.argv[2:]:
    m, pool = spec.split("/")
    variants[spec] = replace(params.horizon, distinct_m=float(m), distinct_pool=int(pool))
items = [i for s in sys.argv[1].split(",") for i in items_on_side(s) if i.key.startswith("ch1/")]
out = []
for n, it, (dem, terrain, model) in with_place(items, None):
    image, sky, w = photo_skyline(it, params)
    H, W = image.shape[:2]
    k = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
    tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
    rec = {"photo": it.key}
    cen = standable_centres(model.horizons, dem, params.max_ground_slope_deg)
    for name, hp in variants.items():
        t = time.perf_counter()
        poses, cost = horizon_poses(model.horizons, sky, w, k, dem, 2.0, hp, centres=cen)
        d = np.hypot(poses[:, 0] - tx, poses[:, 1] - ty)
        rec[name] = {"n": len(poses), "nearest": float(d.min()), "within1k": int((d <= 1000).sum()),
                     "cells2k": len(np.unique(np.floor(poses[:, :2] / 2000.0), axis=0)), "s": time.perf_counter() - t}
    out.append(rec)
    print(it.key[4:30].ljust(27), " | ".join(
        f"{nm}: n {r['n']} near {r['nearest']:.0f} in1k {r['within1k']} cells {r['cells2k']} {r['s']:.1f}s"
        for nm, r in rec.items() if nm != "photo"), flush=True)
os.makedirs("/tmp/prof", exist_ok=True)
json.dump(out, open("/tmp/prof/recall.json", "w"), indent=1)
