"""Per photo, two fov-unknown runs of `real_localize` side by side, with each photo's true fov.

python experiments/ch1/fov-unknown-range/compare.py BEFORE.json [AFTER.json] [--threshold T]

(one run alone: its rows by true fov)

Each row: true horizontal fov (CH1 index), then per run the fov found, the error (m) and the
confidence under the shipped fit (``skyrender/localizer/photo_confidence.json``, recomputed from each
row's refined poses, as ``real_localize --retable --rescore`` does: the older run's rows were scored with
an older fit); the summary counts within 250 m / 1 km, and answered right / wrong at the threshold T,
for all photos and for the telephotos (true fov < 30 deg). Run with the project's Python.
"""

import argparse
import csv
import json
import os
import statistics

import numpy as np

INDEX = os.path.join(os.path.dirname(__file__), "..", "..", "..", "..", "shared", "data", "photos", "ch1", "index.csv")


def rows_of(path):
    with open(path) as f:
        return {r["photo"]: r for r in json.load(f)["photos"] if r["fov_mode"] == "unknown"}


def confidence_of(r):
    from skyrender.benchmarks.real_localize import log_best_of, margin_of
    from skyrender.localizer.confidence import PHOTO_MARGIN_LOGIT, PHOTO_RUNNER_UP_M
    from skyrender.training.localize_fit import confidences

    return float(confidences(np.array([margin_of(r, PHOTO_RUNNER_UP_M)]), np.array([log_best_of(r)]),
                             PHOTO_MARGIN_LOGIT)[0])


def error_of(r):
    return r.get("error_m", r.get("withheld_error_m"))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("before")
    parser.add_argument("after", nargs="?")
    parser.add_argument("--threshold", type=float, default=0.9)
    parser.add_argument("--index", default=INDEX)
    args = parser.parse_args()
    with open(args.index) as f:
        true_fov = {"ch1/" + r["id"]: float(r["hfov_deg"]) for r in csv.DictReader(f)}
    runs = [rows_of(args.before)] + ([rows_of(args.after)] if args.after else [])
    for r in runs:
        for row in r.values():
            row["confidence"] = confidence_of(row)
    names = ("before", "after") if args.after else ("run",)
    keys = sorted(set.intersection(*(set(r) for r in runs)), key=lambda k: (true_fov[k], k))
    print(f"{'photo':34s} {'true':>5s} | " + " | ".join(f"{n + ': fov':>11s} {'error m':>8s} {'conf':>5s}" for n in names))
    for k in keys:
        cells = [f"{r[k]['fov']:11.1f} {error_of(r[k]):8.0f} {r[k]['confidence']:5.2f}" for r in runs]
        print(f"{k:34s} {true_fov[k]:5.1f} | " + " | ".join(cells))
    for label, subset in (("all", keys), ("true fov < 30 deg", [k for k in keys if true_fov[k] < 30.0]),
                          ("true fov >= 30 deg", [k for k in keys if true_fov[k] >= 30.0])):
        print(f"\n{label} ({len(subset)} photos)")
        for name, r in zip(names, runs):
            err = [error_of(r[k]) for k in subset]
            conf = [r[k]["confidence"] for k in subset]
            ans = [(e, c) for e, c in zip(err, conf) if c >= args.threshold]
            print(f"  {name:6s}: within 250 m {sum(e <= 250 for e in err)}, 1 km {sum(e <= 1000 for e in err)}; "
                  f"at >= {args.threshold:.2f}: {sum(e <= 1000 for e, _ in ans)} right, {sum(e > 1000 for e, _ in ans)} wrong; "
                  f"median {statistics.median(r[k]['seconds'] for k in subset) if subset else float('nan'):.1f} s")


if __name__ == "__main__":
    main()
