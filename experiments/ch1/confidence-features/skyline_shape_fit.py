import json, sys
import numpy as np
from skyrender.benchmarks.real_localize import margin_of, split_places
from skyrender.training.localize_fit import abstain_threshold, fit_logistic

place_of = split_places()
info = {}
for s in ("train", "dev"):
    info.update(json.load(open(f"experiments/ch1/confidence-features/skyline-shape-{s}.json")))
rows = json.load(open("experiments/ch1/confidence-train-rows.json"))["rows"]
places = np.array([place_of[r["photo"]] for r in rows])
right = np.array([(r.get("error_m") or np.inf) <= 1000 for r in rows])
m = np.array([margin_of(r) for r in rows])

def conf_of(X, lg):
    return 1 / (1 + np.exp(-(lg[0] + X @ np.array(lg[1:]))))

def judge(X):
    lg = fit_logistic(X, right.astype(float)); c = conf_of(X, lg); t = abstain_threshold(c, right)
    ans = np.zeros(len(right), bool)
    for p in np.unique(places):
        h = places == p
        l2 = fit_logistic(X[~h], right[~h].astype(float)); c2 = conf_of(X, l2); t2 = abstain_threshold(c2[~h], right[~h])
        ans[h] = c2[h] >= t2
    return lg, t, int(np.sum((c >= t) & right)), int(np.sum(ans & right)), int(np.sum(ans & ~right))

for name in ("relief", "tv"):
    f = np.array([info[r["photo"]][name] for r in rows])
    print(name, "right median", np.round(np.median(f[right]), 3), "wrong median", np.round(np.median(f[~right]), 3))
for label, X in (("margin", m[:, None]), ("margin+log relief", np.c_[m, np.log([info[r['photo']]['relief'] + 1e-3 for r in rows])]),
                 ("margin+log tv", np.c_[m, np.log([info[r['photo']]['tv'] + 1e-3 for r in rows])])):
    lg, t, kept, lr, lw = judge(X)
    print(f"{label:18s} kept {kept} at {t:.2f}; leave place out {lr} / {lw}; logit {np.round(lg, 3)}")
