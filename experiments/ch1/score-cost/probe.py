"""The photo score's cost per column, varied (a probe on stored refined poses, 2026-12-05).

``python experiments/ch1/score-cost/probe.py OUT.json [--places 4]``

The score (``verification.score_skylines``) charges a column min(|e|, cap) where the rendered terrain stands above
the photo's skyline and ``occluder_weight`` times that where it stands below (trees, people in front); cap 20 px and
weight 0.25 were set on renders. For each of the 73 training-side rows (``../confidence-train-rows.json``, fov known)
the best ``--places`` distinct places (> 1 km apart) among the refined poses are rendered and scored with other caps,
occluder weights and a squared cost. Reported per variant: photos whose best place lies within 1 km, and the margin
1 - best / next place for right and wrong answers. The poses stay those refined under the shipped score.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from skyrender.benchmarks.real_localize import place_report, stored_places
from skyrender.localizer import LocalizeParams
from skyrender.localizer.verification import column_errors, score_skylines

#: (name, ScoreParams fields, squared)
VARIANTS = [("shipped (cap 20, occluder 0.25)", {}, False),
            ("cap 5", {"cap_px": 5.0}, False), ("cap 10", {"cap_px": 10.0}, False), ("cap 40", {"cap_px": 40.0}, False),
            ("occluder 0.1", {"occluder_weight": 0.1}, False), ("occluder 0.5", {"occluder_weight": 0.5}, False),
            ("occluder 1.0", {"occluder_weight": 1.0}, False),
            ("squared, cap 10", {"cap_px": 10.0}, True), ("squared, cap 20", {}, True)]


def squared_scores(rendered: np.ndarray, sky: np.ndarray, weights: np.ndarray, sp) -> np.ndarray:
    """(P,) root of the weighted mean squared capped cost (the shipped cost's shape, squared)."""
    e = column_errors(rendered, sky, sp.cap_px)
    cost = np.where(e < 0, np.minimum(-e, sp.cap_px), sp.occluder_weight * np.minimum(e, sp.cap_px))
    return np.sqrt((cost ** 2 * weights).sum(axis=-1) / max(float(weights.sum()), 1e-9))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--places", type=int, default=4)
    a = ap.parse_args()
    params = LocalizeParams.for_photos()
    out = []
    for row, it, sky, weights, places, rendered, _ in stored_places(places=a.places, params=params):
        truth = np.asarray(row["truth_xy"])
        rec = {"photo": it.key, "dist_m": [float(np.hypot(*(p[:2] - truth))) for p in places], "scores": {}}
        for name, fields, squared in VARIANTS:
            sp = dataclasses.replace(params.score, **fields)
            s = squared_scores(rendered, sky, weights, sp) if squared else score_skylines(rendered, sky, weights, sp)[0]
            rec["scores"][name] = [float(v) for v in s]
        out.append(rec)
        print(it.key, [round(d / 1000, 1) for d in rec["dist_m"]], flush=True)
    place_report(out, [v[0] for v in VARIANTS], a.out)


if __name__ == "__main__":
    main()
