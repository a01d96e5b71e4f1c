"""Would discounting the columns where a far ridge was lost bring the right place back? (an oracle probe, 2026-12-05)

``python experiments/ch1/lost-columns/probe.py OUT.json KEY [KEY ...]`` (training-side CH1 photos; fov known, no
abstention). Each photo is localized twice with the photo preset from its extracted (``select``) skyline: as
shipped, and with the column confidence set to 0 wherever the extracted line lies more than 5 px below the true one
(a far ridge taken for sky), so those columns weigh nothing in any score. The second is an oracle: the truth picks
the columns. If it does not bring the place back, no confidence cue for such columns can.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from skyrender.benchmarks.real_localize import load_place, places_of
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import position_errors
from skyrender.features import ExtractedSkyline, extract_skyline, load_photo
from skyrender.localizer import LocalizeParams, localize


def main(out: str, keys: list[str]) -> None:
    params = LocalizeParams.from_dict({"min_confidence": 0.0, "min_confidence_fov_unknown": 0.0},
                                      LocalizeParams.for_photos())  # no abstention: every answer is seen
    everything = [it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")]
    place_of, centres = places_of(everything)
    items = {it.key: it for it in everything}
    rows, loaded = [], {}
    for key in keys:
        it = items[key]
        place = place_of[key]
        if place not in loaded:
            loaded.clear()
            loaded[place] = load_place(*centres[place])
        dem, terrain, model, _ = loaded[place]
        truth_xy = np.array([float(v) for v in dem.from_lonlat(it.lon, it.lat)])
        image = load_photo(it.image_path)
        fov = float(np.degrees(2 * np.arctan(image.shape[1] / (2 * it.focal_px))))
        ext = extract_skyline(image, params.skyline_params())
        truth = it.truth_skyline()
        below = np.isfinite(truth) & (np.where(np.isfinite(ext.skyline), ext.skyline, np.inf) > truth + 5)
        row = {"photo": key, "lost_columns": int(below.sum())}
        for name, conf in (("shipped", ext.confidence), ("lost columns at 0", np.where(below, 0.0, ext.confidence))):
            t = time.perf_counter()
            result = localize(image, model, 2.0, fov, terrain=terrain, params=params,
                              skyline=ExtractedSkyline(ext.skyline, conf, ext.sky_probability))
            err = float(position_errors(result.pose, truth_xy)[0]) if result.localized else None
            row[name] = {"status": result.status, "error_m": err, "confidence": result.confidence,
                         "seconds": time.perf_counter() - t}
        rows.append(row)
        a, b = row["shipped"], row["lost columns at 0"]
        print(f"{key:32s} lost {row['lost_columns']:4d} columns | shipped {a['error_m'] or float('nan'):8.0f} m "
              f"at {a['confidence']:.2f} | lost at 0 {b['error_m'] or float('nan'):8.0f} m at {b['confidence']:.2f}",
              flush=True)
    with open(out, "w") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
