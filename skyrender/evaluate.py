"""Evaluation: pose errors, recall, summaries and the paper-style tables.

One module owns how a localization is scored, so the demo, the benchmarks, the
experiment runner and the tests agree. Poses are (N, 6) arrays of
(x, y, z, pan, tilt, swing) in the world frame (metres, degrees; README, Conventions).

- position error: horizontal distance in metres (real photos know no true height);
- orientation error: the largest of the three wrapped angle differences, degrees;
- a result is *localized* when the localizer answered, *right* when it answered within
  ``wrong_m`` of the truth, *wrong* when it answered farther away, *abstained* otherwise.
"""

from __future__ import annotations

import os
import subprocess
from dataclasses import dataclass

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECALL_M = (10.0, 100.0, 1000.0)  # the paper's scale: metres, tens of metres, a kilometre


def position_errors(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(N,) horizontal distance (m) between estimated and true positions; NaN where the
    estimate is NaN (an abstention). Inputs: (N, >=2) or (>=2,) arrays of x, y first."""
    e, t = np.atleast_2d(np.asarray(estimate, float)), np.atleast_2d(np.asarray(truth, float))
    return np.hypot(e[:, 0] - t[:, 0], e[:, 1] - t[:, 1])


def angle_differences(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Wrapped differences a - b of angles in degrees, in [-180, 180)."""
    return (np.asarray(a, float) - np.asarray(b, float) + 180.0) % 360.0 - 180.0


def orientation_errors(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(N,) the largest |wrapped difference| of pan, tilt and swing (degrees) of (N, 6) poses."""
    e, t = np.atleast_2d(np.asarray(estimate, float)), np.atleast_2d(np.asarray(truth, float))
    return np.abs(angle_differences(e[:, 3:6], t[:, 3:6])).max(axis=1)


def recall(position_error_m: np.ndarray, thresholds_m=RECALL_M) -> dict[float, float]:
    """Share of *all* results (abstentions count as misses: NaN error) within each threshold."""
    err = np.asarray(position_error_m, float)
    if err.size == 0:
        return {float(m): 0.0 for m in thresholds_m}
    ok = np.isfinite(err)
    return {float(m): float(np.mean(ok & (np.where(ok, err, np.inf) <= m))) for m in thresholds_m}


def place_interval(values, places, *, level: float = 0.95, resamples: int = 2000, seed: int = 0) -> tuple[float, float]:
    """Bootstrap interval (percentile, ``level``) of the mean of per-photo ``values`` (a 0/1 outcome or a share)
    when whole places are resampled: photos of one place succeed or fail together (one CH1 validation place holds
    27 of the 60 photos), so resampling photos alone would give an interval far too narrow. Each resample draws as
    many places as there are, with replacement, and pools their photos. Deterministic for a seed; (mean, mean) with
    fewer than two places. ``places``: one label per value (any hashable)."""
    from scipy.stats import bootstrap

    v = np.asarray(values, np.float64)
    labels, index = np.unique(np.asarray(places), return_inverse=True)
    if len(labels) < 2:
        return float(v.mean()), float(v.mean())
    sums = np.bincount(index, weights=v, minlength=len(labels))
    counts = np.bincount(index, minlength=len(labels)).astype(np.float64)

    def pooled_mean(drawn, axis=-1):
        drawn = drawn.astype(np.intp)
        return sums[drawn].sum(axis=axis) / counts[drawn].sum(axis=axis)

    ci = bootstrap((np.arange(len(labels)),), pooled_mean, n_resamples=resamples, vectorized=True,
                   method="percentile", confidence_level=level, rng=np.random.default_rng(seed)).confidence_interval
    return float(ci.low), float(ci.high)


def _stats(values: np.ndarray) -> dict:
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"n": 0, "min": None, "mean": None, "median": None, "max": None}
    return {"n": int(v.size), "min": float(v.min()), "mean": float(v.mean()), "median": float(np.median(v)),
            "max": float(v.max())}


@dataclass(frozen=True)
class Summary:
    """What a table row says of one configuration over its views (see :func:`summarize`)."""

    views: int
    localized: int
    right: int
    wrong: int
    abstained: int
    position_m: dict  # stats of the right ones' position errors
    orientation_deg: dict  # stats of the right ones' orientation errors
    seconds: dict  # stats over all views, as a user waits
    recall: dict  # threshold (m) -> share of all views
    hypotheses_per_s: float | None
    rejected_visibility: int
    rejected_skyline: int


def summarize(rows: list[dict], wrong_m: float = 1000.0, thresholds_m=RECALL_M) -> Summary:
    """Summary of result rows (the experiment runner's JSON lines): each with ``localized``
    (bool), ``position_error_m`` / ``orientation_error_deg`` (None when abstained),
    ``seconds`` and optionally ``hypotheses`` and ``rejected`` {constraint: count}."""
    pos = np.array([np.nan if r.get("position_error_m") is None else r["position_error_m"] for r in rows], float)
    ang = np.array([np.nan if r.get("orientation_error_deg") is None else r["orientation_error_deg"] for r in rows],
                   float)
    localized = np.array([bool(r.get("localized")) for r in rows], bool)
    pos = np.where(localized, pos, np.nan)
    right = localized & (pos <= wrong_m)
    seconds = np.array([r.get("seconds", np.nan) for r in rows], float)
    hyps = np.array([r.get("hypotheses", 0) for r in rows], float)
    total_s = float(np.nansum(seconds))
    rejected = [r.get("rejected") or {} for r in rows]
    return Summary(
        views=len(rows), localized=int(localized.sum()), right=int(right.sum()), wrong=int((localized & ~right).sum()),
        abstained=int((~localized).sum()), position_m=_stats(pos[right]), orientation_deg=_stats(ang[right]),
        seconds=_stats(seconds), recall=recall(pos, thresholds_m),
        hypotheses_per_s=float(hyps.sum() / total_s) if total_s > 0 and hyps.sum() > 0 else None,
        rejected_visibility=int(sum(r.get("visibility", 0) for r in rejected)),
        rejected_skyline=int(sum(r.get("skyline", 0) for r in rejected)))


def _fmt(stats: dict, key: str, digits: int) -> str:
    return "–" if stats.get(key) is None else f"{stats[key]:.{digits}f}"


def _triple(stats: dict, digits: int) -> str:
    return "/".join(_fmt(stats, k, digits) for k in ("min", "mean", "max"))


def results_table(summaries: dict[str, Summary], wrong_m: float = 1000.0) -> str:
    """Markdown table in the paper's form, one row per configuration: position error
    min/mean/max (m) and mean orientation error of the right ones, localized / abstained /
    wrong, processing time min/mean/max (s), hypotheses per second, hypotheses rejected by
    the visibility and skyline constraints, and recall at each threshold."""
    thresholds = next(iter(summaries.values())).recall.keys() if summaries else RECALL_M
    head = (["configuration", "views", "position m min/mean/max", "orientation deg mean", "localized", "abstained",
             f"wrong (> {wrong_m:g} m)", "time s min/mean/max", "hyp/s", "rejected vis.", "rejected skyline"]
            + [f"within {m:g} m" for m in thresholds])
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, s in summaries.items():
        cells = [name, str(s.views), _triple(s.position_m, 1), _fmt(s.orientation_deg, "mean", 3), str(s.localized),
                 str(s.abstained), str(s.wrong), _triple(s.seconds, 1),
                 "–" if s.hypotheses_per_s is None else f"{s.hypotheses_per_s:,.0f}", str(s.rejected_visibility),
                 str(s.rejected_skyline)] + [f"{100 * v:.0f} %" for v in s.recall.values()]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def git_commit(short: bool = True) -> str:
    """The repository's commit (``unknown`` outside a git checkout), ``+dirty`` when it has changes."""
    try:
        args = ["git", "rev-parse", "--short", "HEAD"] if short else ["git", "rev-parse", "HEAD"]
        commit = subprocess.run(args, cwd=REPO, capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO, capture_output=True,
                               text=True, check=True).stdout.strip()
        return commit + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


# the libraries whose versions move figures: the same code and seed on another install or CPU refined CH1 poses up to
# 46 m apart and moved no verdict (2026-12-07, experiments/ch1/env-2026-12-07/)
FIGURE_LIBRARIES = ("numpy", "scipy", "mitsuba", "drjit", "opencv-python-headless", "numba", "pillow", "rasterio")


def library_versions() -> dict:
    """Python's and :data:`FIGURE_LIBRARIES`' installed versions (``None`` for one not installed)."""
    import platform
    from importlib.metadata import PackageNotFoundError, version

    def installed(name: str) -> str | None:
        try:
            return version(name)
        except PackageNotFoundError:
            return None

    return {"python": platform.python_version(), **{name: installed(name) for name in FIGURE_LIBRARIES}}


def cpu_description() -> str:
    """The CPU's model and the vector extensions the JIT-compiled kernels (Dr.Jit's LLVM, numba) and BLAS choose by,
    e.g. ``AMD EPYC (avx2, fma)``: the same code can round differently on another CPU. Linux's ``/proc/cpuinfo``
    (``flags`` on x86, ``Features`` on ARM); ``platform.processor()`` elsewhere."""
    import platform

    try:
        with open("/proc/cpuinfo") as f:
            lines = f.read().splitlines()
    except OSError:
        return platform.processor() or "unknown"
    first = {}
    for key, _, value in (line.partition(":") for line in lines):
        first.setdefault(key.strip(), value.strip())
    flags = set((first.get("flags") or first.get("Features") or "").split())
    vector = [f for f in ("avx512f", "avx2", "fma", "asimd") if f in flags]
    return f"{first.get('model name', 'unknown')} ({', '.join(vector) or 'no wide vectors'})"


def versions_line(versions: dict | None) -> str:
    """``numpy 2.4.6, scipy 1.17.1, …`` for a table's header (``versions not recorded`` for an older run)."""
    if not versions:
        return "versions not recorded"
    return ", ".join(f"{name} {v}" for name, v in versions.items() if v is not None)


def machine_line(report: dict) -> str:
    """``2 CPUs (AMD EPYC (avx2, fma); python 3.11.7, numpy 2.4.6, …)``: a benchmark report's ``cpus``,
    ``cpu_model`` (:func:`cpu_description`) and ``versions`` (:func:`versions_line`) for its header; an older
    report without them says so."""
    model = f"{report['cpu_model']}; " if report.get("cpu_model") else ""
    return f"{report['cpus']} CPUs ({model}{versions_line(report.get('versions'))})"


def provenance(**extra) -> dict:
    """Where a figure comes from: git commit, skyrender version, Mitsuba variant, CPU count and model, the libraries'
    versions (:func:`library_versions`), plus ``extra`` (parameters, seeds)."""
    from . import __version__
    from .backend import requested_variant

    return {"commit": git_commit(), "skyrender": __version__, "variant": requested_variant(), "cpus": os.cpu_count(),
            "cpu_model": cpu_description(), "versions": library_versions(), **extra}


def provenance_header(info: dict) -> str:
    """A markdown comment block stating :func:`provenance` (one ``key: value`` a line)."""
    import json

    lines = [f"{k}: {v if isinstance(v, (str, int, float)) else json.dumps(v, sort_keys=True)}" for k, v in info.items()]
    return "<!--\n" + "\n".join(lines) + "\n-->"
