"""A second cue for the photo confidence, tried on the training-side rows only (2026-12-04, issue 19).

``python experiments/ch1/confidence-features/fit_features.py``: logistic fits of P(within 1 km) on the 73
CH1 training-side rows of ``experiments/ch1/confidence-train-rows.json`` with the margin alone (shipped), the
margin and the best refined score (px), the margin and whether another refined pose lies within 1 km of the
answer, and all three; in-sample and leave-one-place-out (the abstention threshold by the shipped rule,
``localize_fit.abstain_threshold``, from the photos fitted on). The validation side is not read.
"""

import json
import os

import numpy as np
from scipy.optimize import minimize

from skyrender.benchmarks.real_localize import margin_of, places_of
from skyrender.datasets.real_photos import REPO, items_on_side
from skyrender.training.localize_fit import RIGHT_M, abstain_threshold

CUES = {"margin": [0], "margin+best": [0, 1], "margin+near": [0, 2], "all": [0, 1, 2]}


def cues(row: dict) -> list[float]:
    """margin, the best refined score (px), 1 if another refined pose lies within 1 km of the answer."""
    poses = np.asarray(row["refined_poses"], float).reshape(-1, 8)
    best = int(np.argmin(poses[:, 7]))
    apart = np.hypot(poses[:, 0] - poses[best, 0], poses[:, 1] - poses[best, 1])
    return [margin_of(row), poses[best, 7], float((apart < 1000).sum() > 1)]


def fit(x: np.ndarray, right: np.ndarray, ridge: float = 1e-3) -> np.ndarray:
    design = np.column_stack([np.ones(len(x)), x])

    def loss(p):
        z = design @ p
        return float(np.sum(np.logaddexp(0, z) - right * z) + ridge * np.sum(p[1:] ** 2))

    return minimize(loss, np.r_[0.0, np.ones(x.shape[1])], method="Nelder-Mead",
                    options={"xatol": 1e-7, "fatol": 1e-10, "maxiter": 20000}).x


def confidence(p: np.ndarray, x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-(np.column_stack([np.ones(len(x)), x]) @ p)))


def answered(c: np.ndarray, threshold: float, right: np.ndarray) -> tuple[int, int]:
    return int(((c >= threshold) & (right == 1)).sum()), int(((c >= threshold) & (right == 0)).sum())


def main() -> None:
    with open(os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")) as f:
        rows = json.load(f)["rows"]
    x = np.array([cues(r) for r in rows])
    right = np.array([r.get("error_m", np.inf) < RIGHT_M for r in rows], float)
    for name, cols in CUES.items():
        p = fit(x[:, cols], right)
        c = confidence(p, x[:, cols])
        kept, wrong = answered(c, abstain_threshold(c, right.astype(bool)), right)
        print(f"in-sample {name:12s}: coefficients {np.round(p, 2)}, threshold {abstain_threshold(c, right.astype(bool)):.2f}, "
              f"right answered {kept}, wrong answered {wrong}")
    items = [it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")]
    place_of, _ = places_of(items)
    places = np.array([place_of[r["photo"]] for r in rows])
    print("places (photos):", ", ".join(f"{p} ({int((places == p).sum())})" for p in sorted(set(places))))
    for name, cols in CUES.items():
        kept = wrong = 0
        out_of_fold = np.zeros(len(rows))
        for place in sorted(set(places)):
            fitted, held = places != place, places == place
            p = fit(x[fitted][:, cols], right[fitted])
            threshold = abstain_threshold(confidence(p, x[fitted][:, cols]), right[fitted].astype(bool))
            out_of_fold[held] = confidence(p, x[held][:, cols])
            k, w = answered(out_of_fold[held], threshold, right[held])
            kept, wrong = kept + k, wrong + w
        nll = -np.sum(right * np.log(out_of_fold) + (1 - right) * np.log(1 - out_of_fold))
        print(f"leave-one-place-out {name:12s}: right answered {kept}, wrong answered {wrong}, out-of-fold NLL {nll:.1f}")


if __name__ == "__main__":
    main()
