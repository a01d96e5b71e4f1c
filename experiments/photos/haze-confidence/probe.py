"""Does a faint colour step above the photo extractor's line say that the line is too low (a pale, hazy far ridge
taken for sky)? A probe on the training-side photos only (``extract.py``'s cache).

Per column, with the line at row v: the Lab step between the 3 rows above and the 3 below each row b in
[v - reach, v - gap], blurred over ``blur`` columns; the cue is its largest value (Lab units), and that value over
the photo's median of it. A logistic regression of "within 5 px" on the extractor's confidence logit alone and
with the cues, fitted leaving each place out (CH1 places; the Web photos one group each of ten).

``python experiments/photos/haze-confidence/probe.py --cache /tmp/haze-cache``
"""
import argparse
import glob
import json

import cv2
import numpy as np
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import roc_auc_score

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import items_on_side

parser = argparse.ArgumentParser()
parser.add_argument("--cache", required=True)
parser.add_argument("--reach", type=float, default=0.3, help="band above the line, share of the height")
parser.add_argument("--gap", type=int, default=4)
parser.add_argument("--blur", type=int, default=15)
args = parser.parse_args()

places = json.load(open("experiments/photos/split.json"))["photos"]
paths = {it.key: it.image_path for side in ("train", "dev") for it in items_on_side(side)}


def step_above(image, skyline, reach_share, gap, blur):
    H, W = image.shape[:2]
    lab = cv2.cvtColor(image.astype(np.float32) / 255.0, cv2.COLOR_RGB2Lab).astype(np.float64)
    csum = np.concatenate([np.zeros((1, W, 3)), np.cumsum(lab, axis=0)])
    b = np.arange(3, H - 2)
    step = np.zeros((H + 1, W))
    step[b] = np.linalg.norm((csum[b] - csum[b - 3]) - (csum[b + 3] - csum[b]), axis=2) / 3.0
    step = cv2.blur(step.astype(np.float32), (blur, 1))
    v = np.where(np.isfinite(skyline), skyline, H)
    rows = np.arange(H + 1)[:, None]
    band = (rows <= v[None, :] - gap) & (rows >= v[None, :] - reach_share * H)
    return np.where(band, step, 0.0).max(axis=0)


X, Y, G, LOW = [], [], [], []
for path in sorted(glob.glob(f"{args.cache}/*.npz")):
    d = np.load(path)
    key = str(d["key"])
    image = cv2.imread(paths[key])[..., ::-1]
    truth = d["truth"]
    ok = np.isfinite(truth)
    err = column_errors(d["skyline"], truth)
    low = np.nan_to_num(d["skyline"], nan=image.shape[0]) - truth > 5  # the line below the truth
    cue = step_above(image, d["skyline"], args.reach, args.gap, args.blur)
    rel = cue / max(np.median(cue), 1e-3)
    conf = np.clip(d["confidence"], 1e-4, 1 - 1e-4)
    X.append(np.column_stack([np.log(conf / (1 - conf)), cue, np.log(rel + 1e-3)])[ok])
    Y.append(err <= 5)
    LOW.append(low[ok])
    group = places.get(key, {}).get("place", key)
    G.append(np.full(ok.sum(), group if key.startswith("ch1") else key[:12] + key[12:14]))
X, Y, G, LOW = map(np.concatenate, (X, Y, G, LOW))
print(f"{len(np.unique(G))} groups, {len(Y)} columns, within 5 px {Y.mean():.3f}, line too low {LOW.mean():.3f}")
for name, cols in (("confidence", [0]), ("+ step", [0, 1]), ("+ step, relative", [0, 1, 2])):
    p = np.zeros(len(Y))
    for g in np.unique(G):
        m = G == g
        p[m] = LogisticRegression(max_iter=1000).fit(X[~m][:, cols], Y[~m]).predict_proba(X[m][:, cols])[:, 1]
    hi = p >= 0.5
    print(f"{name:18s} AUC {roc_auc_score(Y, p):.3f}; >=0.5: {hi.mean():.3f} of columns, {Y[hi].mean():.3f} within 5 px;"
          f" <0.5: {Y[~hi].mean():.3f}; too-low columns at >=0.5: {hi[LOW].mean():.3f}")
    print("   step cue, too-low vs within 5 px columns (median):", np.median(X[LOW, 1]).round(2), np.median(X[Y, 1]).round(2))
