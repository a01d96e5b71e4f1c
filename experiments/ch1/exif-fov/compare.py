"""The CLI's EXIF path as it was (every candidate's focal length refitted, ``refine_fov``) against the fov given
outright, on the 73 CH1 training-side photos, both scored with the shipped photo confidence (2026-12-05, session 15).

``python experiments/ch1/exif-fov/compare.py experiments/ch1/exif-fov/bench-real-train-exif-now.json
experiments/ch1/exif-fov/bench-real-dev-exif-now.json > experiments/ch1/exif-fov/compare.txt``

It reads the shipped rows and fit: those of efc3d2d (session 15). Since 4b5e86b (the DEM grids fixed,
``../dem-window/``) the repository ships others, so run it from a checkout of efc3d2d to get ``compare.txt`` again.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from skyrender.benchmarks.real_localize import log_best_of, margin_of
from skyrender.localizer.confidence import PHOTO_MARGIN_LOGIT, PHOTO_MIN_CONFIDENCE, PHOTO_RUNNER_UP_M
from skyrender.training.localize_fit import TRAINING_ROWS_FILE, confidences


def table(rows: list[dict], name: str) -> None:
    """One line: recall, the answers at the shipped threshold (right, wrong), median error and seconds."""
    margin = np.array([margin_of(r, PHOTO_RUNNER_UP_M) for r in rows])
    confidence = confidences(margin, np.array([log_best_of(r) for r in rows]), PHOTO_MARGIN_LOGIT)
    error = np.array([np.inf if r.get("error_m") is None else r["error_m"] for r in rows])
    answered = confidence >= PHOTO_MIN_CONFIDENCE
    wrong = [(r["photo"], round(float(error[i])), round(float(confidence[i]), 3))
             for i, r in enumerate(rows) if answered[i] and error[i] > 1000.0]
    recall = " / ".join(str(int((error <= d).sum())) for d in (100.0, 250.0, 1000.0))
    print(f"{name}: within 100 m / 250 m / 1 km {recall} of {len(rows)}; answered at >= {PHOTO_MIN_CONFIDENCE}: "
          f"{int(answered.sum())}, right {int((answered & (error <= 1000.0)).sum())}, wrong {wrong}; median error "
          f"within 1 km {np.median(error[error <= 1000.0]):.0f} m; median seconds {np.median([r['seconds'] for r in rows]):.1f}")


def main() -> None:
    with open(TRAINING_ROWS_FILE) as f:
        table(json.load(f)["rows"], "fov given (the shipped rows)")
    rows = []
    for path in sys.argv[1:]:
        with open(path) as f:
            rows += json.load(f)["photos"]
    table(rows, "EXIF path until now (refine_fov)")


if __name__ == "__main__":
    main()
