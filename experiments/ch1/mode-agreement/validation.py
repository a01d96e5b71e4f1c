"""The second opinion scored on a side's rows of both modes (the shipped fit, threshold and second opinion of
``skyrender/localizer/photo_confidence.json``): each fov-given answer as the margin alone gives it, then with the
second opinion (the fov-unknown row of the same photo is what the second search gives), and the seconds a photo
(the fov-unknown row's added where the second search is asked).

    python experiments/ch1/mode-agreement/validation.py ../bench-real-validation.json > validation.txt
"""
import json
import sys

import numpy as np

from skyrender.benchmarks.real_localize import apart_m, margin_of
from skyrender.localizer.confidence import PHOTO_CONFIDENCE_FILE, agreed_confidence, margin_logistic
from skyrender.training.localize_fit import rows_right

fit = json.load(open(PHOTO_CONFIDENCE_FILE))
so = fit["second_opinion"]
rows = json.load(open(sys.argv[1]))["photos"]
known = [r for r in rows if r["fov_mode"] == "known"]
unknown = {r["photo"]: r for r in rows if r["fov_mode"] == "unknown"}
threshold = fit["min_confidence"]
print(f"{sys.argv[1]}: {len(known)} photos; margin fit {fit['logit']}, threshold {threshold:.2f}; second opinion from "
      f"{so['from']:.2f}, gain {so['gain']:.3f}, agree within {so['apart_m']:.0f} m")
err = np.array([np.hypot(*(np.asarray(r['truth_xy']) - np.asarray(sorted(r['refined_poses'], key=lambda p: p[7])[0][:2])))
                for r in known])
right = err <= 1000
assert (right == rows_right([{**r, "error_m": e} for r, e in zip(known, err)])).all()
conf = np.array([margin_logistic(margin_of(r, fit["runner_up_m"]), fit["logit"]) for r in known])
asked = (conf < threshold) & (conf >= so["from"])
apart = np.array([apart_m(r, unknown[r["photo"]]) for r in known])
agreed = np.array([agreed_confidence(c, so["gain"]) if a and ap <= so["apart_m"] else c
                   for c, a, ap in zip(conf, asked, apart)])
alone, given = conf >= threshold, agreed >= threshold
secs_alone = np.array([r["seconds"] for r in known])
secs = secs_alone + np.where(asked, [unknown[r["photo"]]["seconds"] for r in known], 0.0)
n = len(known)
print("photo                               margin conf  asked  apart m   with it   error m  verdict")
for r, c, a, ap, g, e in zip(known, conf, asked, apart, agreed, err):
    verdict = "answered" if c >= threshold else "GAINED" if g >= threshold else "withheld"
    verdict += " right" if e <= 1000 else " WRONG"
    print(f"{r['photo']:36s} {c:11.3f}  {'yes' if a else '-':5s} {ap:8.0f}  {g:8.3f}  {e:8.0f}  {verdict}")
for name, ans, s in (("margin alone (shipped)", alone, secs_alone), ("with the second opinion", given, secs)):
    within = [100 * np.sum(ans & (err <= d)) / n for d in (100, 250, 1000)]
    print(f"{name}: answered within 100 m / 250 m / 1 km {within[0]:.0f} / {within[1]:.0f} / {within[2]:.0f} %; "
          f"answered {int(ans.sum())}, confident and > 1 km wrong {int((ans & ~right).sum())}; "
          f"median {np.median(s):.1f} s (max {s.max():.1f})")
print(f"asked for a second opinion: {int(asked.sum())} of {n}; agreed with: {int((asked & (apart <= so['apart_m'])).sum())}")
