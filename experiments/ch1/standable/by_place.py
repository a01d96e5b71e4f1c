"""Training-side rows of two runs, each scored with its own photo confidence fit: per place, the photos
answered within 1 km and answered wrong (over 1 km), and within 1 km without abstaining.

    python experiments/ch1/standable/by_place.py BEFORE_ROWS.json BEFORE_FIT.json AFTER_ROWS.json AFTER_FIT.json
"""
import json
import sys
from collections import defaultdict

import numpy as np

from skyrender.benchmarks.real_localize import log_best_of, margin_of, split_places
from skyrender.localizer.confidence import margin_logistic

place_of = split_places()
runs = []
for rows_path, fit_path in ((sys.argv[1], sys.argv[2]), (sys.argv[3], sys.argv[4])):
    rows, fit = json.load(open(rows_path))["rows"], json.load(open(fit_path))
    per = defaultdict(lambda: [0, 0, 0, 0])  # photos, answered right, answered wrong, right without abstaining
    for r in rows:
        m = margin_of(r, fit["runner_up_m"])
        conf = float(margin_logistic(m, fit["logit"], log_best_of(r))) if np.isfinite(m) else 0.0
        err = r.get("error_m") if r.get("error_m") is not None else np.inf
        p = per[place_of.get(r["photo"], "?")]
        p[0] += 1
        p[1] += int(conf >= fit["min_confidence"] and err <= 1000)
        p[2] += int(conf >= fit["min_confidence"] and err > 1000)
        p[3] += int(err <= 1000)
    runs.append(per)
print(f"{'place':10s} photos | before: right / wrong answered, right without abstaining | after: the same")
for place in sorted(set(runs[0]) | set(runs[1])):
    a, b = runs[0][place], runs[1][place]
    print(f"{place:10s} {a[0]:6d} | {a[1]:3d} / {a[2]:d}, {a[3]:3d} | {b[1]:3d} / {b[2]:d}, {b[3]:3d}")
for name, per in (("before", runs[0]), ("after", runs[1])):
    t = np.sum(list(per.values()), axis=0)
    print(f"{name}: {t[0]} photos, answered right {t[1]}, answered wrong {t[2]}, right without abstaining {t[3]}")
