"""Where do CH1 cameras stand in their terrain: on ridges, on slopes or in valleys? (a diagnostic)

``python experiments/ch1/stance-tpi/tpi.py > experiments/ch1/stance-tpi/tpi.txt`` (from the repository root)

For each of the 73 training-side photos (the rows of ``../confidence-train-rows.json``: fov given, no abstention), the
topographic position of the true camera and of the answer: the SRTM3 ground there less the mean ground 250, 500 and
1,000 m around it (24 directions each), and its percentile among 400 random points of the place's DEM window (5 km
in from its edges).
"""

from __future__ import annotations

import json

import numpy as np

from skyrender.benchmarks.real_localize import place_dem, places_of
from skyrender.datasets.real_photos import items_on_side

RADII_M = np.array([250.0, 500.0, 1000.0])
DIRECTIONS = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)


def topographic_position(dem, x: float, y: float) -> float:
    """The ground at (x, y) less the mean ground on circles of :data:`RADII_M` around it (m; + on a rise)."""
    xs = x + np.outer(RADII_M, np.cos(DIRECTIONS)).ravel()
    ys = y + np.outer(RADII_M, np.sin(DIRECTIONS)).ravel()
    return float(dem.ground(np.array([x]), np.array([y]))[0] - np.nanmean(dem.ground(xs, ys)))


def main() -> None:
    with open("experiments/ch1/confidence-train-rows.json") as f:
        rows = {r["photo"]: r for r in json.load(f)["rows"]}
    items = [it for side in ("train", "dev") for it in items_on_side(side) if it.key in rows]
    place_of, centres = places_of(items)
    rng = np.random.default_rng(0)
    truth_pct, answer_pct, right = [], [], []
    current = None
    for it in sorted(items, key=lambda i: place_of[i.key]):
        place = place_of[it.key]
        if place != current:
            dem, current = place_dem(*centres[place])[0], place
            x0, x1, y0, y1 = dem.extent
            reference = np.array([topographic_position(dem, a, b) for a, b in
                                  zip(rng.uniform(x0 + 5000, x1 - 5000, 400), rng.uniform(y0 + 5000, y1 - 5000, 400))])
        row = rows[it.key]
        tx, ty = row["truth_xy"]
        best = min(row["refined_poses"], key=lambda q: q[-1])
        is_right = float(np.hypot(best[0] - tx, best[1] - ty)) < 1000
        t, a = topographic_position(dem, tx, ty), topographic_position(dem, best[0], best[1])
        truth_pct.append(float(np.mean(reference < t)))
        answer_pct.append(float(np.mean(reference < a)))
        right.append(is_right)
        print(f"{it.key:32s} {place:12s} right={is_right!s:5s} tpi_truth {t:7.1f} pct {truth_pct[-1]:.2f} | "
              f"tpi_answer {a:7.1f} pct {answer_pct[-1]:.2f}", flush=True)
    truth_pct, answer_pct, right = np.array(truth_pct), np.array(answer_pct), np.array(right)
    print("truth percentile: median", np.median(truth_pct), "quartiles", np.percentile(truth_pct, [25, 75]))
    print("wrong answers percentile: median", np.median(answer_pct[~right]), "quartiles",
          np.percentile(answer_pct[~right], [25, 75]))
    print("right answers percentile: median", np.median(answer_pct[right]))


if __name__ == "__main__":
    main()
