"""The fov-unknown rows with the other coarse fovs' candidates refined too, alone and with the re-ranking, against
those without, on the 41 training-side photos, by the rules of README.md.

``python experiments/ch1/other-fov-runner-up/compare.py > experiments/ch1/other-fov-runner-up/compare.txt``
"""

from __future__ import annotations

import json
import os

import numpy as np

from skyrender.benchmarks.real_localize import log_best_of, margin_of
from skyrender.localizer.pipeline import PHOTO_MARGIN_LOGIT, PHOTO_MIN_CONFIDENCE, PHOTO_RUNNER_UP_M
from skyrender.training.localize_fit import confidences, fov_unknown_threshold, rows_right

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = {"shipped (../dem-window/unknown/)": [os.path.join(HERE, "..", "dem-window", "unknown",
                                                            f"bench-real-{s}-unknown-{s}.json") for s in ("train", "dev")],
        "other fovs refined (this folder)": [os.path.join(HERE, f"bench-real-{s}-other-fov.json") for s in ("train", "dev")],
        "both: other fovs refined and re-ranked (this folder)": [os.path.join(HERE, f"bench-real-{s}-both.json")
                                                                 for s in ("train", "dev")]}


def main() -> None:
    for name, paths in RUNS.items():
        if not all(os.path.exists(p) for p in paths):
            continue
        rows = [r for p in paths for r in json.load(open(p))["photos"]]
        error = np.array([r.get("error_m", np.inf) for r in rows])
        confidence = confidences(np.array([margin_of(r, PHOTO_RUNNER_UP_M) for r in rows]),
                                 np.array([log_best_of(r) for r in rows]), PHOTO_MARGIN_LOGIT)
        threshold = fov_unknown_threshold(rows, PHOTO_MARGIN_LOGIT, PHOTO_RUNNER_UP_M, PHOTO_MIN_CONFIDENCE)
        answered = confidence >= threshold
        right = rows_right(rows)
        wrong_top = sorted(((float(c), r["photo"], round(float(e))) for c, r, e in zip(confidence, rows, error)
                            if e > 1000.0), reverse=True)[:3]
        fov_err = [abs(r["fov"] - r.get("true_fov", np.nan)) for r in rows if "fov" in r and "true_fov" in r]
        print(f"{name}: {len(rows)} photos; best place within 100 m / 250 m / 1 km: "
              f"{int((error <= 100).sum())} / {int((error <= 250).sum())} / {int(right.sum())}; median error within "
              f"1 km {np.median(error[right]):.0f} m; threshold {threshold:.2f}: answered {int(answered.sum())}, right "
              f"{int((answered & right).sum())}; most confident > 1 km: "
              + ", ".join(f"{p} {e} m at {c:.3f}" for c, p, e in wrong_top)
              + f"; median seconds {np.median([r['seconds'] for r in rows]):.1f}"
              + (f"; median |fov error| {np.median(fov_err):.2f} deg" if fov_err else ""))
        for c, r, e in sorted(zip(confidence, rows, error), key=lambda t: -t[0])[:14]:
            print(f"    {r['photo']:34s} {c:.4f} {e:9.0f} m  fov {r.get('fov', float('nan')):.2f}")


if __name__ == "__main__":
    main()
