"""Offline: a soft slope penalty on the refined scores instead of a hard bound. Each refined pose's score s
becomes s (1 + g max(0, slope - 15 deg) / 10 deg); the answer is the lowest, its runner-up the lowest over 1 km
away; the confidence is refitted on the training rows (localize_fit's rule) and judged place by place. With
--validation the fit and threshold chosen on the training rows are applied to a validation run's rows once.
The refined poses do not depend on how the answer is chosen among them, so rows of any run that kept
``refined_slopes`` give the answers exactly.

    python experiments/ch1/standable/soft_penalty.py TRAIN_ROWS.json [--validation VALIDATION_RUN.json --penalty G]
"""
import argparse
import json

import numpy as np

from skyrender.benchmarks.real_localize import split_places
from skyrender.localizer.confidence import runner_up_index
from skyrender.training.localize_fit import abstain_threshold, fit_logistic, leave_place_out

parser = argparse.ArgumentParser()
parser.add_argument("train")
parser.add_argument("--validation")
parser.add_argument("--penalty", type=float, default=0.05)
args = parser.parse_args()
place_of = split_places()


def answer(r, g, s0=15.0):
    """(margin, error of the answer (m), answer's slope) under penalty g per 10 deg over s0."""
    P = np.asarray(r["refined_poses"], float)
    slope = np.nan_to_num(np.asarray(r["refined_slopes"], float))
    s = P[:, 7] * (1 + g * np.maximum(0.0, slope - s0) / 10.0)
    b = int(np.argmin(s))
    i = runner_up_index(P[:, :2], s, b, 1000.0)
    return (1 - s[b] / s[i] if i is not None else 1.0,
            float(np.hypot(P[b, 0] - r["truth_xy"][0], P[b, 1] - r["truth_xy"][1])), float(slope[b]))


def confidence(margin, logit):
    return 1 / (1 + np.exp(-(logit[0] + logit[1] * margin)))


rows = json.load(open(args.train))["rows"]
places = np.array([place_of[r["photo"]] for r in rows])
fits = {}
print("training side: penalty | within 1 km without abstaining | right above the threshold | leave place out right / wrong | per place within 1 km")
for g in (0.0, 0.05, 0.1, 0.2):
    A = np.array([answer(r, g) for r in rows])
    margin, right = A[:, 0], A[:, 1] <= 1000.0
    logit = fit_logistic(margin[:, None], right.astype(float))
    conf = confidence(margin, logit)
    t = abstain_threshold(conf, right)
    loo = leave_place_out(margin, np.zeros(len(rows)), right, places, score_term=False)
    per = {p: int(np.sum(right[places == p])) for p in sorted(set(places))}
    fits[g] = (logit, t)
    print(f"{g:4.2f} | {right.sum()} | {int(np.sum((conf >= t) & right))} at {t:.2f} | {loo['right']} / {loo['wrong']} | " + ", ".join(f"{p[4:]} {v}" for p, v in per.items()))

if args.validation:
    vrows = [r for r in json.load(open(args.validation))["photos"] if r["fov_mode"] == "known"]
    print(f"validation ({len(vrows)} photos), each with the fit and threshold of its training rows:")
    for g in (0.0, args.penalty):
        logit, t = fits[g]
        A = np.array([answer(r, g) for r in vrows])
        conf = confidence(A[:, 0], logit)
        err, ans = A[:, 1], conf >= t
        n = len(vrows)
        within = [int(np.sum(ans & (err <= d))) for d in (100, 250, 1000)]
        wrong = [(r["photo"], round(e), round(c, 2)) for r, e, c, a in zip(vrows, err, conf, ans) if a and e > 1000]
        print(f"penalty {g:4.2f}: answered within 100 / 250 / 1000 m {' / '.join(f'{100 * w / n:.0f}' for w in within)} %, "
              f"answered {int(ans.sum())}, confident and > 1 km wrong {len(wrong)} {wrong}, "
              f"within 1 km without abstaining {int(np.sum(err <= 1000))}")
