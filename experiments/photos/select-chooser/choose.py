"""Step 2 of the chooser probe: how much better could ``select`` choose between ``hybrid`` and ``gmm``?

Per training-side photo (``extract.py``'s cache): the share of columns within 5 px and the target (median <= 2 px and
>= 95 % within 5 px) for hybrid, gmm, select as shipped, the better of the two (an oracle), and choosers fitted
leaving each place out (CH1 places; Web photos in blocks of ten), a logistic regression of "gmm is the better" on
cues of the disputed columns, used on the photos where the two part.

``python experiments/photos/select-chooser/choose.py CACHE_DIR``
"""

from __future__ import annotations

import glob
import json
import sys

import numpy as np
from sklearn.linear_model import LogisticRegression

from skyrender.benchmarks.skyline_photos import column_errors


def scored(skyline, truth):
    e = column_errors(skyline, truth)
    return float(np.mean(e <= 5)), bool(np.median(e) <= 2 and np.mean(e <= 5) >= 0.95)


def cues(d):
    """Cues of the disputed columns (the two lines > 5 px apart)."""
    H = int(d["height"])
    a, b = (np.where(np.isfinite(d[m]), d[m], H + 1e3) for m in ("hybrid", "gmm"))
    apart = np.abs(a - b) > 5
    ch, cg = d["hybrid_conf"], d["gmm_conf"]
    if not apart.any():
        return None
    return [ch[apart].mean() - cg[apart].mean(),  # the shipped rule's cue
            np.mean(apart),
            np.mean(b[apart] < a[apart]),  # gmm above the hybrid on the disputed columns
            ch.mean() - cg.mean(),
            np.median(np.abs(a - b)[apart]) / H]


def main(cache: str) -> None:
    places = json.load(open("experiments/photos/split.json"))["photos"]
    rows = []
    for path in sorted(glob.glob(f"{cache}/*.npz")):
        d = np.load(path)
        key = str(d["key"])
        truth = d["truth"]
        r = {"key": key, "side": str(d["side"]),
             "group": places[key]["place"] if key.startswith("ch1") else "web" + key[-3:-1],
             "cues": cues(d)}
        for m in ("hybrid", "gmm", "select"):
            r[m] = scored(d[m], truth)
        rows.append(r)
    disputed = [r for r in rows if r["cues"] is not None]
    X = np.array([r["cues"] for r in disputed])
    y = np.array([r["gmm"][0] > r["hybrid"][0] for r in disputed])
    groups = np.array([r["group"] for r in disputed])
    for name, cols in (("rule's cue", [0]), ("all cues", [0, 1, 2, 3, 4]), ("rule + direction", [0, 2])):
        take_gmm = np.zeros(len(disputed), bool)
        for g in np.unique(groups):
            m = groups == g
            if len(set(y[~m].tolist())) < 2:
                continue
            model = LogisticRegression(max_iter=1000).fit(X[~m][:, cols], y[~m])
            take_gmm[m] = model.predict_proba(X[m][:, cols])[:, 1] > 0.5
        for r, t in zip(disputed, take_gmm):
            r[name] = r["gmm"] if t else r["hybrid"]
    for r in rows:
        r["oracle"] = max(r["hybrid"], r["gmm"])
        for name in ("rule's cue", "all cues", "rule + direction"):
            r.setdefault(name, r["hybrid"])
    for side in ("dev", "train"):
        on = [r for r in rows if r["side"] == side]
        print(f"{side} ({len(on)} photos, {sum(r['cues'] is not None for r in on)} disputed)")
        for m in ("hybrid", "gmm", "select", "oracle", "rule's cue", "rule + direction", "all cues"):
            print(f"  {m:18s} met {sum(r[m][1] for r in on):3d}  mean within 5 px {100 * np.mean([r[m][0] for r in on]):.1f}%"
                  f"  lowest {100 * min(r[m][0] for r in on):.1f}%")


if __name__ == "__main__":
    main(sys.argv[1])
