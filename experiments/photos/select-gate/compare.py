"""The select extractor with the gate (gmm only where the hybrid doubts more than 2 % of its columns)
beside select without it (gmm always), on every photo of the given sides: whether the skyline and
confidence are the same to the bit, whether gmm ran, both errors against the truth, both times.

``python experiments/photos/select-gate/compare.py OUT.json SIDE [SIDE ...]``
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo
from skyrender.features.skyline import _edge_strength, _extract, hybrid_in_doubt, pixel_features, remove_cables


def main(out: str, sides: list[str]) -> None:
    gated, always = SkylineParams(method="select", select_gmm_above=0.02), SkylineParams(method="select")
    rows = []
    for side in sides:
        for it in items_on_side(side):
            image = load_photo(it.image_path)
            truth = it.truth_skyline()
            rec = {"photo": it.key, "side": side}
            for name, params in (("always", always), ("gated", gated)):
                t = time.perf_counter()
                r = extract_skyline(image, params)
                rec[name + "_s"] = time.perf_counter() - t
                e = column_errors(r.skyline, truth)
                rec[name] = {"median": float(np.median(e)), "within5": float(np.mean(e <= 5)),
                             "met": bool(meets_target(np.median(e), np.mean(e <= 5)))}
                rec[name + "_arrays"] = r
            a, g = rec.pop("always_arrays"), rec.pop("gated_arrays")
            rec["identical"] = bool(np.array_equal(a.skyline, g.skyline, equal_nan=True)
                                    and np.array_equal(a.confidence, g.confidence))
            clean, _ = remove_cables(image, gated.cables)
            features = pixel_features(clean)
            hybrid = _extract(clean, features, _edge_strength(features, gated.edge_percentile), "hybrid", gated)
            rec["gmm_ran"] = hybrid_in_doubt(hybrid, gated.select_gmm_above)
            rows.append(rec)
            print(f"{it.key} {side} identical {rec['identical']} gmm {rec['gmm_ran']} "
                  f"{rec['always']['within5']:.3f} -> {rec['gated']['within5']:.3f} "
                  f"{rec['always_s']:.2f} -> {rec['gated_s']:.2f} s", flush=True)
    json.dump(rows, open(out, "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
