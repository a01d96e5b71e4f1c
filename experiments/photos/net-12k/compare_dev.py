"""A network trained longer, against the shipped one, on the dev (or training) photos.

``python experiments/photos/net-12k/compare_dev.py ONNX SIDE OUT CACHE`` (run 2026-12-04 for seeds 0 and 1 on
dev, seed 0 on train): ``net``, ``hybrid`` and ``select`` with the network ``ONNX`` (its ``_fit.json`` beside it,
from ``python -m skyrender.training.skyline_fit --weights ONNX``), beside the previous network's ``old_*``
output saved in ``CACHE`` by ``experiments/photos/select/extract.py`` (``gmm``, which uses no network, comes
from there too). Per photo the share of columns within 5 px and whether the target is met -> ``OUT/SIDE.json``."""

from __future__ import annotations

import json
import os
import sys

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo
from skyrender.features.skyline import ExtractedSkyline, select_skylines

NAMES = ("net", "hybrid", "select", "old_net", "old_hybrid", "old_select")


def met(e: np.ndarray) -> bool:
    return bool(meets_target(np.median(e), np.mean(e <= 5)))


def main(weights: str, side: str, out: str, cache: str) -> None:
    os.makedirs(out, exist_ok=True)
    res = {}
    for it in items_on_side(side):
        key = it.key.replace("/", "__")
        old = np.load(f"{cache}/{key}.npz")
        image = load_photo(it.image_path)
        new = {m: extract_skyline(image, SkylineParams(method=m, net_weights=weights)) for m in ("net", "hybrid")}
        gmm = ExtractedSkyline(old["gmm"], old["gmm_conf"], np.zeros((image.shape[0], 1)))
        old_hybrid = ExtractedSkyline(old["hybrid"], old["hybrid_conf"], np.zeros((image.shape[0], 1)))
        skylines = {"net": new["net"].skyline, "hybrid": new["hybrid"].skyline,
                    "select": select_skylines(new["hybrid"], gmm).skyline, "old_net": old["net"],
                    "old_hybrid": old["hybrid"], "old_select": select_skylines(old_hybrid, gmm).skyline}
        row = {}
        for name, skyline in skylines.items():
            e = column_errors(skyline, old["truth"])
            row[name] = (float(np.mean(e <= 5)), met(e))
        res[it.key] = row
        print(it.key, {a: round(b[0], 3) for a, b in row.items()}, flush=True)
    with open(f"{out}/{side}.json", "w") as f:
        json.dump(res, f)
    for name in NAMES:
        v = [r[name] for r in res.values()]
        print(f"{side} {name:11s} met {sum(m for _, m in v):3d}/{len(v)} mean within 5 px "
              f"{100 * np.mean([a for a, _ in v]):.1f} %  lowest {100 * min(a for a, _ in v):.1f}")


if __name__ == "__main__":
    main(*sys.argv[1:5])
