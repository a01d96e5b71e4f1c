"""Would the inner-ridge support add to the photo confidence? (offline, on ``probe.py``'s output and the training rows)

``python experiments/ch1/inner-ridges/confidence.py inner-train.json [--kept] [--rows ROWS.json]``

The answer's support (its occluding contours on photo edges, less chance) beside the margin: AUC of each for right
against wrong answers, and the logistic of margin + support judged a place at a time (``localize_fit.leave_place_out``'s
rule, written out here for two features): right and wrong answers given, against the margin alone. With ``--kept``,
also the fit on all rows: its threshold (the shipped rule) and the right answers it keeps.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np
from scipy.stats import mannwhitneyu

from skyrender.benchmarks.real_localize import margin_of, places_of
from skyrender.datasets.real_photos import REPO
from skyrender.training.localize_fit import abstain_threshold, fit_logistic

ROWS = os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")


def confidence(feats: np.ndarray, logit) -> np.ndarray:
    return 1 / (1 + np.exp(-(logit[0] + feats @ np.asarray(logit[1:]))))


def main(path: str, kept: bool = False, rows_path: str = ROWS) -> None:
    """``rows_path``: the training rows the support was probed on (``probe.py --rows``; default the shipped ones)."""
    support = {r["photo"]: r["places"][0]["support"] for r in json.load(open(path))}
    rows = json.load(open(rows_path))["rows"]
    place_of, _ = places_of([])
    right = np.array([r["error_m"] <= 1000 for r in rows])
    margin = np.array([margin_of(r) for r in rows])
    sup = np.nan_to_num(np.array([support[r["photo"]] for r in rows]), nan=0.0)
    places = np.array([place_of[r["photo"]] for r in rows])
    for name, x in (("margin", margin), ("support", sup)):
        u = mannwhitneyu(x[right], x[~right])
        print(f"{name}: AUC right > wrong {u.statistic / right.sum() / (~right).sum():.3f} (p {u.pvalue:.3g})")
    models = (("margin", margin[:, None]), ("margin + support", np.c_[margin, sup]))
    for name, feats in models:
        answered = np.zeros(len(rows), bool)
        for place in np.unique(places):
            held = places == place
            logit = fit_logistic(feats[~held], right[~held].astype(float))
            threshold = abstain_threshold(confidence(feats[~held], logit), right[~held])
            answered[held] = confidence(feats[held], logit) >= threshold
        full = fit_logistic(feats, right.astype(float))
        print(f"{name}: leave place out answered right {int(np.sum(answered & right))} / wrong "
              f"{int(np.sum(answered & ~right))} of {int(right.sum())}; fit on all {np.round(full, 3)}")
    if kept:
        for name, feats in models:
            conf = confidence(feats, fit_logistic(feats, right.astype(float)))
            threshold = abstain_threshold(conf, right)
            print(f"{name}: threshold {threshold:.2f}, right kept {int(np.sum((conf >= threshold) & right))} of "
                  f"{int(right.sum())}")


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], "--kept" in args, args[args.index("--rows") + 1] if "--rows" in args else ROWS)
