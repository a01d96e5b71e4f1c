"""Does the colour mixtures' EM need its whole budget? ``select`` on the dev photos (or another side) with the EM's
stop tolerance, step limit or sample count changed, against the shipped settings, in one process, variants taking
turns on each photo (so the machine's drift falls on all of them alike).

    python experiments/photos/em-budget/probe.py --side dev --out experiments/photos/em-budget/dev.json
    python experiments/photos/em-budget/probe.py --side dev --combined --out experiments/photos/em-budget/dev-combined.json
    python experiments/photos/em-budget/probe.py --side train --combined --out experiments/photos/em-budget/train-combined.json

Per variant: the target (median <= 2 px and >= 95 % within 5 px) met, the mean share within 5 px, the skylines equal to
the shipped ones, the median wall seconds and the median CPU seconds (both cores' work: steadier than the wall on a
drifting machine).

Since 825eec0 the budget is a parameter of the extractor (``SkylineParams.mixture_tol``, ``mixture_samples``; the step
limit stays the module's ``sky.GMM_MAX_ITER``), and ``select``'s own is the smaller one. "shipped" names the budget
that was shipped when this ran, 1e-3 and 12,000, now set explicitly, so the commands give the same skylines as then.
"""

from __future__ import annotations

import argparse
import json
import time
from contextlib import contextmanager
from dataclasses import replace

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.features import SkylineParams, extract_skyline, load_photo, sky

BEFORE = {"mixture_tol": 1e-3, "mixture_samples": 12_000}
SINGLE = {
    "shipped": BEFORE,
    "tol 1e-2": {**BEFORE, "mixture_tol": 1e-2},
    "max 15 steps": {**BEFORE, "GMM_MAX_ITER": 15},
    "6,000 samples": {**BEFORE, "mixture_samples": 6_000},
}
COMBINED = {
    "shipped": BEFORE,
    "tol 1e-2, 6,000": {"mixture_tol": 1e-2, "mixture_samples": 6_000},
    "tol 1e-2, 6,000, 15": {"mixture_tol": 1e-2, "mixture_samples": 6_000, "GMM_MAX_ITER": 15},
}


@contextmanager
def variant(params: SkylineParams, settings: dict):
    """``params`` with the variant's budget, the module's step limit set for the block."""
    saved = {k: getattr(sky, k) for k in settings if k.startswith("GMM_")}
    for k, v in settings.items():
        if k.startswith("GMM_"):
            setattr(sky, k, v)
    try:
        yield replace(params, **{k: v for k, v in settings.items() if not k.startswith("GMM_")})
    finally:
        for k, v in saved.items():
            setattr(sky, k, v)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--side", default="dev")
    ap.add_argument("--out", required=True)
    ap.add_argument("--combined", action="store_true", help="the combinations instead of one change at a time")
    args = ap.parse_args(argv)
    variants = COMBINED if args.combined else SINGLE
    params = SkylineParams(method="select")
    items = items_on_side(args.side)
    extract_skyline(load_photo(items[0].image_path), params)  # warm-up: numba, the network
    rows = {name: [] for name in variants}
    for item in items:
        image, truth = load_photo(item.image_path), item.truth_skyline()
        shipped = None
        for name, settings in variants.items():
            with variant(params, settings) as budgeted:
                wall, cpu = time.perf_counter(), time.process_time()
                result = extract_skyline(image, budgeted)
                wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            shipped = result.skyline if shipped is None else shipped
            e = column_errors(result.skyline, truth)
            rows[name].append({"photo": item.key, "median_px": float(np.median(e)), "within5": float(np.mean(e <= 5)),
                               "same": bool(np.array_equal(result.skyline, shipped, equal_nan=True)),
                               "wall_s": wall, "cpu_s": cpu})
        print(item.key, " ".join(f"{r[-1]['within5']:.3f}/{r[-1]['wall_s']:.2f}" for r in rows.values()), flush=True)
    summary = {}
    for name, r in rows.items():
        met = sum(meets_target(x["median_px"], x["within5"]) for x in r)
        summary[name] = {"met": met, "photos": len(r), "mean_within5": float(np.mean([x["within5"] for x in r])),
                         "same_skylines": sum(x["same"] for x in r),
                         "wall_s": float(np.median([x["wall_s"] for x in r])),
                         "cpu_s": float(np.median([x["cpu_s"] for x in r]))}
        s = summary[name]
        print(f"{name:14s} met {met}/{len(r)}, mean within 5 px {100 * s['mean_within5']:.1f} %, same skylines "
              f"{s['same_skylines']}, wall {s['wall_s']:.2f} s, cpu {s['cpu_s']:.2f} s")
    json.dump({"commit": git_commit(), "side": args.side, "variants": variants, "summary": summary, "rows": rows},
              open(args.out, "w"), indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
