"""Blur the photo's skyline to the DEM's resolution before scoring (a probe on stored refined poses, 2026-12-05).

``python experiments/ch1/dem-blur/probe.py OUT.json [--places 4] [--cells 0.5 1.0]``

SRTM's 90 m cells cannot draw a ridge's detail finer than about f * 90 m / d px at distance d (18 px at 5 km with a
1,000 px focal length), while the photo's skyline has it: at the right place part of the residual is that detail.
For each of the 73 training-side rows (``../confidence-train-rows.json``, fov known) the best ``--places`` distinct
places (> 1 km apart) among the refined poses are rendered with each column's terrain distance, and scored
(the photo preset's ``score_skylines``) against the photo's extracted skyline as it is and blurred column by column
by a Gaussian of sigma = c * f * 90 m / d (c from ``--cells``; at most 30 px). Reported: for each c, how many photos
have their best-scoring place within 1 km (0 = the plain score, which should give the stored answers), and the
margin 1 - best / best beyond 1 km for right and wrong answers.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.ndimage import gaussian_filter1d

from skyrender.benchmarks.real_localize import place_report, stored_places
from skyrender.localizer import LocalizeParams
from skyrender.localizer.verification import score_skylines

CELL_M = 90.0
SIGMAS = np.arange(0.0, 30.01, 0.5)


def blurred_levels(skyline: np.ndarray) -> np.ndarray:
    """(len(SIGMAS), W): the skyline blurred by each sigma (px), NaN columns left out of the blur and kept NaN."""
    ok = np.isfinite(skyline)
    v = np.where(ok, skyline, 0.0)
    out = np.empty((len(SIGMAS), len(skyline)))
    for i, s in enumerate(SIGMAS):
        if s == 0:
            out[i] = skyline
            continue
        num, den = gaussian_filter1d(v, s, mode="nearest"), gaussian_filter1d(ok.astype(float), s, mode="nearest")
        out[i] = np.where(ok, num / np.maximum(den, 1e-9), np.nan)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--places", type=int, default=4)
    ap.add_argument("--cells", type=float, nargs="+", default=[0.5, 1.0])
    a = ap.parse_args()
    params = LocalizeParams.for_photos()
    out = []
    for row, it, sky, weights, places, rendered, distance in stored_places(places=a.places, with_distance=True,
                                                                           params=params):
        W = len(sky)
        levels = blurred_levels(sky)
        truth = np.asarray(row["truth_xy"])
        rec = {"photo": it.key, "dist_m": [float(np.hypot(*(p[:2] - truth))) for p in places],
               "stored_px": [float(p[7]) for p in places], "scores": {}}
        for c in [0.0] + list(a.cells):
            scores = []
            for j, p in enumerate(places):
                sigma = np.clip(c * p[6] * CELL_M / np.where(np.isfinite(distance[j]), distance[j], 1e9), 0, 30)
                level = np.clip(np.round(sigma / 0.5).astype(int), 0, len(SIGMAS) - 1)
                photo = levels[level, np.arange(W)]
                scores.append(float(score_skylines(rendered[j][None], photo, weights, params.score)[0][0]))
            rec["scores"][str(c)] = scores
        out.append(rec)
        print(it.key, {c: [round(s, 2) for s in v] for c, v in rec["scores"].items()},
              [round(d / 1000, 1) for d in rec["dist_m"]], flush=True)
    place_report(out, [str(c) for c in [0.0] + list(a.cells)], a.out)


if __name__ == "__main__":
    main()
