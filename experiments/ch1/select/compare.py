"""Two ``real_localize`` runs of the same photos (fov known, every refined pose kept), both scored with the
shipped photo confidence (``skyrender/localizer/photo_confidence.json``): per photo the error and confidence
of each, then within 100 m / 250 m / 1 km answered, abstentions, confident and wrong, and within 1 km
without abstaining.

``python experiments/ch1/select/compare.py BEFORE.json AFTER.json``
"""

from __future__ import annotations

import json
import sys

import numpy as np

from skyrender.benchmarks.real_localize import margin_of
from skyrender.localizer.confidence import PHOTO_CONFIDENCE_FILE, margin_logistic


def scored(path: str, fit: dict) -> dict:
    rows = {}
    for r in json.load(open(path))["photos"]:
        if r.get("fov_mode", "known") != "known":
            continue
        m = margin_of(r)
        conf = float(margin_logistic(m, fit["logit"])) if np.isfinite(m) else 0.0
        err = r.get("error_m") if r.get("error_m") is not None else r.get("withheld_error_m")
        rows[r["photo"]] = (np.inf if err is None else float(err), conf, r.get("seconds", np.nan))
    return rows


def summary(rows: dict, keys: list[str], threshold: float) -> str:
    err = np.array([rows[k][0] for k in keys])
    conf = np.array([rows[k][1] for k in keys])
    sec = np.array([rows[k][2] for k in keys])
    answered = conf >= threshold
    n = len(keys)
    within = [int(np.sum(answered & (err <= d))) for d in (100, 250, 1000)]
    return (f"within 100 m / 250 m / 1 km {within[0]} / {within[1]} / {within[2]} of {n} "
            f"({100 * within[0] / n:.0f} / {100 * within[1] / n:.0f} / {100 * within[2] / n:.0f} %); "
            f"answered {int(answered.sum())}, abstained {int((~answered).sum())}, "
            f"confident and > 1 km wrong {int(np.sum(answered & (err > 1000)))}; "
            f"without abstaining within 1 km {int(np.sum(err <= 1000))}; median {np.nanmedian(sec):.1f} s")


def main(before: str, after: str) -> None:
    fit = json.load(open(PHOTO_CONFIDENCE_FILE))
    a, b = scored(before, fit), scored(after, fit)
    keys = [k for k in a if k in b]
    t = fit["min_confidence"]
    for k in keys:
        (ea, ca, _), (eb, cb, _) = a[k], b[k]
        flag = "" if (ea <= 1000) == (eb <= 1000) else ("  <- now within 1 km" if eb <= 1000 else "  <- lost")
        print(f"{k:32s} {ea:9.0f} m {ca:.2f} | {eb:9.0f} m {cb:.2f}{flag}")
    print(f"confidence {fit['logit']}, abstaining below {t}")
    print("before:", summary(a, keys, t))
    print("after: ", summary(b, keys, t))


if __name__ == "__main__":
    main(*sys.argv[1:3])
