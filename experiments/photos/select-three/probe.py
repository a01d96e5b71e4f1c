"""``select`` among three: the network's own line as a third candidate (2026-12-05, session 15; a probe).

``python experiments/photos/select-three/probe.py OUT.json --sides dev train``

The hybrid computes the network's line on its way (its first boundary search), so offering it to ``select`` costs
nothing. Per photo: ``hybrid``, ``gmm`` and ``net`` extracted as the photo extractor does (cables painted over, the same
features and edges), then ``select_skylines`` as shipped (hybrid against gmm) and once more, its winner against
``net``; printed per side: photos at the target and the mean share of columns within 5 px, for each.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, load_photo
from skyrender.features.cables import remove_cables
from skyrender.features.sky import pixel_features
from skyrender.features.skyline import _edge_strength, _extract, select_skylines

WAYS = ("hybrid", "gmm", "net", "select", "select + net")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--sides", nargs="+", default=["dev"])
    args = ap.parse_args()
    params = SkylineParams(method="select")
    out = {}
    for side in args.sides:
        rows = []
        for it in items_on_side(side):
            image = load_photo(it.image_path)
            if params.cables is not None:
                image, _ = remove_cables(image, params.cables)
            features = pixel_features(image)
            edges = _edge_strength(features, params.edge_percentile)
            got = {m: _extract(image, features, edges, m, params) for m in ("hybrid", "gmm", "net")}
            got["select"] = select_skylines(got["hybrid"], got["gmm"], params.select_tol_px)
            got["select + net"] = select_skylines(got["select"], got["net"], params.select_tol_px)
            truth = it.truth_skyline()
            row = {"photo": it.key}
            for way in WAYS:
                e = column_errors(got[way].skyline, truth)
                row[way] = {"median": float(np.median(e)), "within5": float(np.mean(e <= 5.0))}
            rows.append(row)
        out[side] = rows
        for way in WAYS:
            met = sum(meets_target(r[way]["median"], r[way]["within5"]) for r in rows)
            print(f"{side:6s} {way:13s} met {met:3d} of {len(rows)}, mean within 5 px "
                  f"{100 * np.mean([r[way]['within5'] for r in rows]):.1f} %", flush=True)
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
