"""The training-side localizations (fov given, no abstention) with the EM budget patch against the rows the shipped
photo confidence was fitted on (``experiments/ch1/confidence-train-rows.json``), photo by photo: the error, whether
within 1 km, and the margin confidence under the shipped fit (``photo_confidence.json``'s logistic of
1 - best / runner-up), with the answers at or above its threshold (0.95) counted right and wrong.

    python experiments/photos/em-budget/compare_train.py experiments/ch1/confidence-train-rows.json \
        experiments/photos/em-budget/localize/bench-real-train-em-budget.json \
        experiments/photos/em-budget/localize/bench-real-dev-em-budget.json
"""

from __future__ import annotations

import json
import sys

import numpy as np

FIT = json.load(open("skyrender/localizer/photo_confidence.json"))


def confidence(row: dict) -> float:
    a, b = FIT["logit"]
    best, runner = row.get("best_score"), row.get("runner_up_score")
    if best is None:
        return 0.0
    margin = 1.0 if runner is None or not np.isfinite(runner) else 1.0 - best / runner
    return float(1.0 / (1.0 + np.exp(-(a + b * margin))))


def rows_of(path: str) -> dict:
    doc = json.load(open(path))
    return {r["photo"]: r for r in doc.get("rows", doc.get("photos", [])) if r.get("fov_mode", "known") == "known"}


def main(argv: list[str]) -> int:
    before = rows_of(argv[0])
    after = {}
    for path in argv[1:]:
        after.update(rows_of(path))
    keys = [k for k in before if k in after]
    threshold = FIT["min_confidence"]
    summary = {"before": [0, 0, 0, 0], "after": [0, 0, 0, 0]}  # within 250 m, within 1 km, right given, wrong given
    print(f"{'photo':36s} {'before m':>9s} {'conf':>5s} | {'after m':>9s} {'conf':>5s}")
    for k in keys:
        line = [f"{k:36s}"]
        for name, rows in (("before", before), ("after", after)):
            r = rows[k]
            e = r.get("error_m")
            e = np.inf if e is None else float(e)
            c = confidence(r)
            s = summary[name]
            s[0] += e <= 250
            s[1] += e <= 1000
            s[2] += c >= threshold and e <= 1000
            s[3] += c >= threshold and e > 1000
            line.append(f"{e:9.0f} {c:5.2f}")
        print(" | ".join(line))
    for name, s in summary.items():
        print(f"{name}: {len(keys)} photos, within 250 m {s[0]}, within 1 km {s[1]}, "
              f"given at >= {threshold:.2f}: {s[2]} right, {s[3]} wrong")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
