"""Score the refined places counting the far skyline more than the near (a probe on stored refined poses, 2026-12-05).

``python experiments/ch1/distance-trust/probe.py OUT.json [--places 4]``

At the true place the photo departs from the SRTM skyline most where the terrain is near (ridges rounded by 90 m
cells, trees on them: ``../near-skylines/``). The verification has a distance trust for renders
(``ScoreParams.trust_near_m`` / ``trust_far_m``: near columns charged ``untrusted_px`` instead of their error), which
the photo preset's ranking and the refined score do not use. For each of the 73 training-side rows
(``../confidence-train-rows.json``, fov known) the best ``--places`` distinct places (> 1 km apart) among the refined
poses are rendered with each column's terrain distance and scored against the extracted skyline with the plain score
and with trust ramps (``charge``: untrusted share of a column charged ``untrusted_px``; ``drop``: the column's
weight scaled by its trust). Reported per variant: photos whose best place lies within 1 km, and the margin
1 - best / next place for right and wrong answers. The poses stay those refined under the plain score.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from skyrender.benchmarks.real_localize import place_report, stored_places
from skyrender.localizer import LocalizeParams
from skyrender.localizer.verification import score_skylines, trust_of_distance

#: (name, near m, far m, mode)
VARIANTS = [("plain", 0.0, 0.0, "none"),
            ("charge 500-4000", 500.0, 4000.0, "charge"), ("charge 1000-3000", 1000.0, 3000.0, "charge"),
            ("charge 2000-8000", 2000.0, 8000.0, "charge"),
            ("drop 500-4000", 500.0, 4000.0, "drop"), ("drop 1000-3000", 1000.0, 3000.0, "drop"),
            ("drop 2000-8000", 2000.0, 8000.0, "drop"),
            ("near only 0-2000", 0.0, 2000.0, "near"),
            ("near x2 0-2000", 0.0, 2000.0, "boost2"), ("near x4 0-2000", 0.0, 2000.0, "boost4"),
            ("near x2 0-5000", 0.0, 5000.0, "boost2"), ("near x4 0-5000", 0.0, 5000.0, "boost4")]


def variant_scores(rendered, distance, sky, weights, score_params, near, far, mode) -> np.ndarray:
    """(P,) scores of rendered skylines (P, W) with terrain distances (P, W) under one variant."""
    if mode == "none":
        return score_skylines(rendered, sky, weights, score_params)[0]
    sp = dataclasses.replace(score_params, trust_near_m=near, trust_far_m=far)
    d = np.where(np.isfinite(distance), distance, 1e9)
    trust = trust_of_distance(d, sp)
    if mode == "charge":
        return score_skylines(rendered, sky, weights, sp, trust=trust)[0]
    if mode == "near":  # the opposite: only the near columns
        trust = 1.0 - trust
    elif mode.startswith("boost"):  # near columns weighted up to this many times the far ones
        trust = 1.0 + (float(mode[5:]) - 1.0) * (1.0 - trust)
    return np.array([score_skylines(rendered[i][None], sky, weights * trust[i], sp)[0][0]
                     for i in range(len(rendered))])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--places", type=int, default=4)
    a = ap.parse_args()
    params = LocalizeParams.for_photos()
    out = []
    for row, it, sky, weights, places, rendered, distance in stored_places(places=a.places, with_distance=True,
                                                                           params=params):
        truth = np.asarray(row["truth_xy"])
        near_share = [float(np.mean(np.where(np.isfinite(d), d, 1e9) < 2000)) for d in distance]
        rec = {"photo": it.key, "dist_m": [float(np.hypot(*(p[:2] - truth))) for p in places],
               "stored_px": [float(p[7]) for p in places], "near2km_share": near_share, "scores": {}}
        for name, near, far, mode in VARIANTS:
            rec["scores"][name] = [float(s) for s in variant_scores(rendered, distance, sky, weights, params.score,
                                                                    near, far, mode)]
        out.append(rec)
        print(it.key, [round(d / 1000, 1) for d in rec["dist_m"]],
              {n: [round(s, 2) for s in v] for n, v in rec["scores"].items() if n in ("plain", "charge 500-4000")},
              flush=True)
    place_report(out, [v[0] for v in VARIANTS], a.out)


if __name__ == "__main__":
    main()
