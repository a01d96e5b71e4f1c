"""The part margins of ``probe.py``'s output as a confidence cue beside the margin: AUC, the fit and threshold of the
shipped rule (``localize_fit.fit_at``, the part margin in the place of the score term), kept right answers, and
the leave-place-out counts. ``python experiments/ch1/split-half/analyse.py SPLIT.json``"""

from __future__ import annotations

import json
import sys

import numpy as np
from scipy.stats import mannwhitneyu

from skyrender.benchmarks.real_localize import places_of
from skyrender.training.localize_fit import RIGHT_M, fit_at, leave_place_out


def auc(values: np.ndarray, right: np.ndarray) -> float:
    """P(a right answer's value > a wrong one's)."""
    u = mannwhitneyu(values[right], values[~right])
    return float(u.statistic / (right.sum() * (~right).sum()))


def main(path: str) -> None:
    rows = json.load(open(path))
    right = np.array([r["error_m"] <= RIGHT_M for r in rows])
    margin = np.array([r["margin"] for r in rows])
    place_of, _ = places_of([])
    places = np.array([place_of.get(r["photo"], r["photo"]) for r in rows])
    print(f"{len(rows)} photos, {right.sum()} right (within {RIGHT_M:.0f} m)")
    for name in ("margin", "halves", "thirds"):
        cue = margin if name == "margin" else np.array([min(r[name]) for r in rows])
        line = f"{name:7s} AUC {auc(cue, right):.3f}"
        if name != "margin":
            fit = fit_at(margin, cue, right, score_term=True)
            kept = int(np.sum((fit["confidence"] >= fit["threshold"]) & right))
            wrong_top = max(zip(fit["confidence"][~right], np.array([r["photo"] for r in rows])[~right]))
            lpo = leave_place_out(margin, cue, right, places, score_term=True)
            line += (f" | margin + smallest part margin: logit {np.round(fit['logit'], 2).tolist()}, threshold "
                     f"{fit['threshold']:.2f} (most confident wrong {wrong_top[1]} at {wrong_top[0]:.2f}), kept right "
                     f"{kept}; leave place out right {lpo['right']} / wrong {lpo['wrong']} of {lpo['of']}")
        else:
            fit = fit_at(margin, np.zeros(len(rows)), right)
            lpo = leave_place_out(margin, np.zeros(len(rows)), right, places, score_term=False)
            line += (f" | margin alone: threshold {fit['threshold']:.2f}, kept right "
                     f"{int(np.sum((fit['confidence'] >= fit['threshold']) & right))}; leave place out right "
                     f"{lpo['right']} / wrong {lpo['wrong']} of {lpo['of']}")
        print(line)


if __name__ == "__main__":
    main(sys.argv[1])
