"""How far the photo confidence's cut-off moves with the training photos: the margin at which the fov-given
logistic (``localize_fit.fit_logistic`` of "within 1 km" on the margin) reaches 0.95, refitted on training places
resampled whole (2,000 resamples, seed 0), for the rows the shipped fit was made from and for the new extractor's.
Training rows only; no validation row is read.

``python experiments/photos/em-budget/shipped/threshold_bootstrap.py``
``  > experiments/photos/em-budget/shipped/threshold-bootstrap.txt``
"""

import json
import os

import numpy as np

from skyrender.benchmarks.real_localize import margin_of
from skyrender.training.localize_fit import fit_logistic, rows_right

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", "..", "..", ".."))


def cut_off(margin: np.ndarray, right: np.ndarray, p: float = 0.95) -> float:
    a, b = fit_logistic(margin, right)[:2]
    return (np.log(p / (1 - p)) - a) / b


def main(resamples: int = 2000, seed: int = 0) -> None:
    with open(os.path.join(REPO, "experiments", "photos", "split.json")) as f:
        place = {k: v["place"] for k, v in json.load(f)["photos"].items()}
    with open(os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")) as f:
        shipped_rows = json.load(f)["rows"]
    new_rows = []
    for side in ("train", "dev"):
        with open(os.path.join(HERE, "..", "localize", f"bench-real-{side}-em-budget.json")) as f:
            new_rows += json.load(f)["photos"]
    rng = np.random.default_rng(seed)
    for name, rows in (("the shipped fit's rows (4179bb5)", shipped_rows), ("the new extractor's rows", new_rows)):
        margin = np.array([margin_of(r, 1000.0) for r in rows])
        right = rows_right(rows).astype(float)
        places = np.array([place[r["photo"]] for r in rows])
        names = np.unique(places)
        members = {p: np.flatnonzero(places == p) for p in names}
        cuts = []
        for _ in range(resamples):
            idx = np.concatenate([members[p] for p in rng.choice(names, len(names))])
            if 0 < right[idx].sum() < len(idx):
                cuts.append(cut_off(margin[idx], right[idx]))
        cuts = np.array(cuts)
        print(f"{name}: {len(rows)} photos of {len(names)} places; margin at 0.95: {cut_off(margin, right):.3f}; "
              f"over {len(cuts)} resamples of whole places: median {np.median(cuts):.3f}, 5-95 % "
              f"{np.percentile(cuts, 5):.3f}-{np.percentile(cuts, 95):.3f}, 90th percentile {np.percentile(cuts, 90):.3f}")


if __name__ == "__main__":
    main()
