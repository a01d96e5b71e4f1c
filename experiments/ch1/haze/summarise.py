"""Right against wrong answers by the aerial-perspective cue of ``haze_cue.py``'s output.

``python experiments/ch1/haze/summarise.py OUT.json``   (-> haze-train.txt)
"""

from __future__ import annotations

import json
import sys

import numpy as np
from scipy.stats import mannwhitneyu


def auc(low: np.ndarray, high: np.ndarray) -> tuple[float, float]:
    """P(a value of ``low`` exceeds one of ``high``) and the Mann-Whitney p."""
    u = mannwhitneyu(low, high)
    return u.statistic / len(low) / len(high), u.pvalue


def main(path: str) -> None:
    rows = [x for x in json.load(open(path)) if "best" in x and x["error_m"] is not None]
    right = np.array([x["error_m"] <= 1000 for x in rows])
    corr = np.array([x["best"]["corr"] for x in rows])
    runner = np.array([x.get("runner_up", {}).get("corr", np.nan) for x in rows])
    confidence = np.array([x["confidence"] for x in rows])
    ok = np.isfinite(corr)
    print("rows", len(rows), "finite corr", ok.sum(), "right", right.sum())
    print("corr right: median %.2f  mean %.2f" % (np.median(corr[ok & right]), corr[ok & right].mean()))
    print("corr wrong: median %.2f  mean %.2f" % (np.median(corr[ok & ~right]), corr[ok & ~right].mean()))
    print("AUC (wrong>right)", *auc(corr[ok & ~right], corr[ok & right]))
    diff = corr - runner
    both = np.isfinite(diff)
    print("diff best-runner AUC", *auc(diff[both & ~right], diff[both & right]), "n", both.sum())
    sure = confidence > 0.5
    print("conf>0.5 right corr", np.round(np.sort(corr[sure & right]), 2))
    print("conf>0.5 wrong corr", np.round(np.sort(corr[sure & ~right]), 2))


if __name__ == "__main__":
    main(sys.argv[1])
