"""The answer's support as a photo-confidence cue: how many of the best SUPPORT_POSES refined poses (by score) lie
within 1 km of the answer (the answer counted). Refined poses start from different far-horizon candidates; a right
place is often reached from several, a look-alike from one.

Fitted and chosen on the training side only (the em-budget rows of the shipped extractor, fov given, 73 photos; the
fov-unknown threshold on the 73 fov-unknown training rows), then the validation rows scored once (``--validation``).
The photo confidence is the logistic of the margin m, plus e ln(n) with n the support. Both fits below are judged
without the second opinion (it needs a second search the rows do not all have), so the two columns compare like with
like, not with the shipped headline.

``python experiments/ch1/support/probe.py [--validation]``
"""
import argparse
import json

import numpy as np

from skyrender.benchmarks.real_localize import answer_xy, margin_of, places_of, refined_of
from skyrender.training.localize_fit import abstain_threshold, fit_logistic, rows_right

SUPPORT_POSES = 4
L = "experiments/photos/em-budget/localize/"
S = "experiments/photos/em-budget/shipped/"


def rows_of(*paths):
    return [r for p in paths for r in json.load(open(p))["photos"]]


def support(r, k=SUPPORT_POSES, within_m=1000.0):
    P = refined_of(r)
    if not len(P):
        return np.nan
    o = np.argsort(P[:, 7], kind="stable")
    return float(np.sum(np.hypot(*(P[o[:k], :2] - P[o[0], :2]).T) <= within_m))


def features(rows, with_support):
    m = np.array([margin_of(r, 1000.0) for r in rows])
    return np.c_[m, np.log([support(r) for r in rows])] if with_support else m[:, None]


def conf(X, logit):
    ok = np.isfinite(X).all(1)
    z = logit[0] + np.nan_to_num(X) @ np.array(logit[1:])
    return np.where(ok, 1 / (1 + np.exp(-z)), 0.0)


def error_of(r):
    """m from the truth to the row's answer, given or withheld (inf without one)."""
    return float(np.nan_to_num(np.hypot(*(answer_xy(r) - np.array(r["truth_xy"]))), nan=np.inf))


def summary(name, rows, c, th):
    e = np.array([error_of(r) for r in rows])
    a = c >= th
    n = len(rows)
    return (f"{name:28s} answered {a.sum():2d}, within 100/250/1000 m {np.sum(a & (e <= 100)) / n:.0%} / "
            f"{np.sum(a & (e <= 250)) / n:.0%} / {np.sum(a & (e <= 1000)) / n:.0%}, wrong > 1 km {np.sum(a & (e > 1000))}"
            + "".join(f"\n      wrong: {r['photo']} {ei / 1e3:.0f} km at {ci:.3f}" for r, ei, ci, ai in zip(rows, e, c, a)
                      if ai and ei > 1000))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--validation", action="store_true", help="score the validation rows once with both fits")
    args = parser.parse_args()
    known = rows_of(L + "bench-real-train-em-budget.json", L + "bench-real-dev-em-budget.json")
    unknown = rows_of(S + "bench-real-train-unknown.json", S + "bench-real-dev-unknown.json")
    place_of, _ = places_of([])
    right, right_u = rows_right(known), rows_right(unknown)
    places = np.array([place_of.get(r["photo"], r["photo"]) for r in known])
    fits = {}
    for name, ws in (("margin", False), ("margin + ln support", True)):
        X, Xu = features(known, ws), features(unknown, ws)
        ok = np.isfinite(X).all(1)
        logit = fit_logistic(X[ok], right[ok].astype(float))
        c = conf(X, logit)
        th = abstain_threshold(c, right)
        th_u = max(th, abstain_threshold(conf(Xu, logit), right_u))
        held = np.zeros(len(known), bool)
        for p in np.unique(places):
            h = places == p
            lg = fit_logistic(X[ok & ~h], right[ok & ~h].astype(float))
            ch = conf(X, lg)
            held[h] = ch[h] >= abstain_threshold(ch[~h], right[~h])
        fits[name] = (ws, logit, th, th_u)
        print(f"{name}: logit {np.round(logit, 3).tolist()}, threshold {th:.2f} (fov unknown {th_u:.2f}); training, fov "
              f"given: {np.sum((c >= th) & right)} right / {np.sum((c >= th) & ~right)} wrong answered of {right.sum()} "
              f"right; fov unknown: {np.sum((conf(Xu, logit) >= th_u) & right_u)} right / "
              f"{np.sum((conf(Xu, logit) >= th_u) & ~right_u)} wrong of {right_u.sum()}; leave place out (fov given): "
              f"{np.sum(held & right)} right / {np.sum(held & ~right)} wrong")
    if args.validation:
        v = json.load(open("experiments/ch1/bench-real-validation.json"))["photos"]
        for mode in ("known", "unknown"):
            rows = [r for r in v if r["fov_mode"] == mode]
            print(f"validation, fov {mode} ({len(rows)} photos; no second opinion):")
            for name, (ws, logit, th, th_u) in fits.items():
                print("   " + summary(name, rows, conf(features(rows, ws), logit), th if mode == "known" else th_u))


if __name__ == "__main__":
    main()
