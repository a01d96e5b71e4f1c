"""Fit the real-photo confidence of the localizer on the CH1 photos of the training side.

``python -m skyrender.training.localize_fit [--limit N]``

Each CH1 photo of the training and dev sides (``experiments/photos/split.json``) is
localized with :meth:`LocalizeParams.for_photos` and no abstention (``min_confidence``
0), its skyline extracted by the photo preset's extractor, the fov known. Per photo the
margin m = 1 - best / runner-up refined score is recorded with whether the answer lies
within 1 km of the true position; a logistic P(within 1 km) = 1 / (1 + exp(-(a + b m)))
is fitted by maximum likelihood (scipy) and written with the rows and the abstention
threshold (:func:`abstain_threshold`) to ``skyrender/localizer/photo_confidence.json``,
which the photo preset reads. The validation side is never used here.
"""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize

from ..benchmarks.real_localize import run
from ..datasets.real_photos import DEFAULT_PHOTOS, items_on_side
from ..evaluate import git_commit
from ..localizer import LocalizeParams
from ..localizer.pipeline import PHOTO_CONFIDENCE_FILE

RIGHT_M = 1000.0


def margin_of(row: dict) -> float:
    """1 - best / runner-up refined score; 1 without a runner-up, NaN without a pose."""
    best, runner = row.get("best_score"), row.get("runner_up_score")
    if best is None:
        return float("nan")
    return 1.0 - best / runner if runner else 1.0


def fit_logistic(margin: np.ndarray, right: np.ndarray, ridge: float = 1e-3) -> tuple[float, float]:
    """(a, b) maximising the likelihood of ``right`` (bool) under logistic(a + b margin),
    with a small ridge on b (separable data would send it to infinity)."""
    def loss(p):
        z = p[0] + p[1] * margin
        return float(np.sum(np.logaddexp(0.0, z) - right * z) + ridge * p[1] ** 2)

    return tuple(float(v) for v in minimize(loss, np.array([0.0, 1.0]), method="Nelder-Mead",
                                            options={"xatol": 1e-6, "fatol": 1e-9, "maxiter": 4000}).x)


def abstain_threshold(confidence: np.ndarray, right: np.ndarray, floor: float = 0.5, step: float = 0.05) -> float:
    """The photo preset's abstention threshold, from the training photos only: above the most
    confident wrong answer (rounded up to ``step``), and never below ``floor`` (an answer must
    be more likely right than wrong)."""
    wrong = confidence[~right.astype(bool) & np.isfinite(confidence)]
    top = float(wrong.max()) if len(wrong) else 0.0
    return float(min(1.0, max(floor, np.ceil((top + 1e-9) / step) * step)))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=0, help="at most N photos, spread over the places")
    parser.add_argument("--out", default=PHOTO_CONFIDENCE_FILE)
    args = parser.parse_args(argv)
    if not os.path.isdir(DEFAULT_PHOTOS):
        print(f"no photos at {DEFAULT_PHOTOS}")
        return 2
    items = [it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")]
    if args.limit:
        items = items[:: max(1, len(items) // args.limit)][: args.limit]
    rows = run(items, ["known"], params=replace(LocalizeParams.for_photos(), min_confidence=0.0))
    margin = np.array([margin_of(r) for r in rows])
    right = np.array([r.get("error_m", np.inf) <= RIGHT_M for r in rows], float)
    ok = np.isfinite(margin)
    a, b = fit_logistic(margin[ok], right[ok])
    confidence = np.where(ok, 1.0 / (1.0 + np.exp(-(a + b * np.nan_to_num(margin)))), 0.0)
    threshold = abstain_threshold(confidence, right > 0)
    out = {"commit": git_commit(), "logit": [a, b], "min_confidence": threshold, "right_m": RIGHT_M, "photos": len(rows),
           "right": int(right.sum()), "rows": [{"photo": r["photo"], "margin": m, "error_m": r.get("error_m"),
                                                "seconds": r["seconds"]} for r, m in zip(rows, margin)]}
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1)
    print(f"{len(rows)} photos, {int(right.sum())} within {RIGHT_M:.0f} m; logit a = {a:.3f}, b = {b:.3f}; "
          f"abstain below {threshold:.2f}; "
          f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
