"""Benchmarks that print figures and ratios against baselines measured in the same run."""

import json
import os
import time


def median_seconds(fn, repeats: int) -> float:
    """Median wall time (s) of ``fn()`` over ``repeats`` runs after one warm-up run: every
    benchmark times its figure and its baseline this way."""
    import numpy as np

    fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def write_figures(path: str, figures: dict, **extra) -> str:
    """Write a benchmark's ``figures`` as JSON at ``path`` with their provenance (git
    commit, skyrender version, Mitsuba variant, CPU count; :func:`skyrender.evaluate.provenance`).
    Returns the path."""
    from ..evaluate import provenance

    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        json.dump({"provenance": provenance(**extra), "figures": figures}, f, indent=1, default=float)
        f.write("\n")
    return path
