"""Score against the sky-probability map instead of the hard skyline (a probe, 2026-12-05).

``PYTHONPATH=. python experiments/ch1/soft-score/run.py SIDE OUT_DIR KEY [KEY ...]``

With ``verification.SOFT`` set (this probe's code only), a column's error is the probability mass between the
rendered and the photo's line (P(sky) where the render puts terrain above the line, 1 - P(sky) where below)
instead of the distance: the same where the map is sure, less where it doubts (a hazy ridge taken for sky).
Every stage that scores a pose uses it (verification, refinement's sweeps, local search, least squares,
final score). The photos are localized with the photo preset, fov known, no abstention.
"""

from __future__ import annotations

import json
import os
import sys
from dataclasses import replace

import numpy as np

import skyrender.features as features
from skyrender.benchmarks.real_localize import run, summary
from skyrender.datasets.real_photos import items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer import verification

_extract = features.extract_skyline


def extract_and_set(image, params):
    result = _extract(image, params)
    p = np.asarray(result.sky_probability, np.float64)
    zeros = np.zeros((1, p.shape[1]))
    verification.SOFT = (np.vstack([zeros, np.cumsum(p, axis=0)]), np.vstack([zeros, np.cumsum(1.0 - p, axis=0)]))
    return result


def main(side: str, out: str, keys: list[str]) -> None:
    features.extract_skyline = extract_and_set
    items = [it for it in items_on_side(side) if it.key in set(keys)]
    rows = run(items, ["known"], params=replace(LocalizeParams.for_photos(), min_confidence=0.0))
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, f"soft-{side}.json"), "w") as f:
        json.dump({"photos": rows, "summary": summary(rows)}, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
