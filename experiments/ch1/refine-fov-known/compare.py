"""Two ``real_localize`` runs of the same photos (fov known, every refined pose kept), each scored with its own
photo confidence fit: per photo the error and confidence of each, then the summary of ``select/compare.py``.

``python experiments/ch1/refine-fov-known/compare.py BEFORE.json BEFORE_FIT.json AFTER.json AFTER_FIT.json``
"""

from __future__ import annotations

import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "select"))
from compare import scored, summary  # noqa: E402  (experiments/ch1/select/compare.py)


def main(before: str, before_fit: str, after: str, after_fit: str) -> None:
    fits = [json.load(open(p)) for p in (before_fit, after_fit)]
    a, b = scored(before, fits[0]), scored(after, fits[1])
    keys = [k for k in a if k in b]
    for k in keys:
        (ea, ca, _), (eb, cb, _) = a[k], b[k]
        flag = "" if (ea <= 1000) == (eb <= 1000) else ("  <- now within 1 km" if eb <= 1000 else "  <- lost")
        print(f"{k:32s} {ea:9.0f} m {ca:.2f} | {eb:9.0f} m {cb:.2f}{flag}")
    for name, rows, fit in (("before", a, fits[0]), ("after ", b, fits[1])):
        print(f"{name}: confidence {[round(v, 3) for v in fit['logit']]}, abstaining below {fit['min_confidence']}; "
              + summary(rows, keys, fit["min_confidence"]))


if __name__ == "__main__":
    main(*sys.argv[1:5])
