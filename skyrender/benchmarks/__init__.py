"""Benchmarks that print figures and ratios against baselines measured in the same run."""

import json
import os


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
