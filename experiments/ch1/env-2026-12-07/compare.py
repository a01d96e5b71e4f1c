"""The same commit's validation rows from two installs, photo by photo: how far a fresh install moves the figures.

    python experiments/ch1/env-2026-12-07/compare.py experiments/ch1/bench-real-validation.json \
        experiments/ch1/env-2026-12-07/bench-real-validation-env.json
"""
from __future__ import annotations

import json
import sys

import numpy as np


def verdict(row: dict) -> str:
    """``right`` (answered within 1 km), ``wrong`` (answered beyond), ``withheld right`` / ``withheld`` (abstained:
    the withheld answer within 1 km or not)."""
    near = row.get("error_m") is not None and row["error_m"] <= 1000.0
    if row["status"] == "localized":
        return "right" if near else "wrong"
    best = row.get("refined_poses")
    if best and row.get("truth_xy"):
        poses = np.asarray(best, float)
        i = int(np.argmin(poses[:, 7]))
        near = float(np.hypot(*(poses[i, :2] - np.asarray(row["truth_xy"], float)))) <= 1000.0
    return "withheld right" if near else "withheld"


def main(before_path: str, after_path: str) -> None:
    before = {(r["photo"], r["fov_mode"]): r for r in json.load(open(before_path))["photos"]}
    after = {(r["photo"], r["fov_mode"]): r for r in json.load(open(after_path))["photos"]}
    keys = sorted(set(before) & set(after))
    for mode in ("known", "unknown"):
        ks = [k for k in keys if k[1] == mode]
        if not ks:  # a run of one fov mode only
            continue
        same_bits = sum(before[k].get("refined_poses") == after[k].get("refined_poses")
                        and before[k]["status"] == after[k]["status"] for k in ks)
        moved = [abs(before[k]["error_m"] - after[k]["error_m"]) for k in ks
                 if before[k].get("error_m") is not None and after[k].get("error_m") is not None]
        changed = [(k[0], verdict(before[k]), verdict(after[k]), before[k].get("error_m"), after[k].get("error_m"),
                    before[k]["confidence"], after[k]["confidence"]) for k in ks if verdict(before[k]) != verdict(after[k])]
        print(f"fov {mode}: {len(ks)} photos; every refined pose and the status the same to the bit on {same_bits}; "
              f"verdict changed on {len(changed)}; error moved by median {np.median(moved) if moved else 0:.0f} m "
              f"(max {max(moved) if moved else 0:.0f} m) where both have one")
        for name, v0, v1, e0, e1, c0, c1 in changed:
            f = lambda e: "-" if e is None else f"{e:.0f} m"  # noqa: E731
            print(f"  {name}: {v0} ({f(e0)}, {c0:.2f}) -> {v1} ({f(e1)}, {c1:.2f})")
        sec0 = np.median([before[k]["seconds"] for k in ks])
        sec1 = np.median([after[k]["seconds"] for k in ks])
        confidence_moved = [abs(before[k]["confidence"] - after[k]["confidence"]) for k in ks]
        print(f"  confidence moved by median {np.median(confidence_moved):.3f} (max {max(confidence_moved):.2f}); "
              f"median seconds {sec0:.1f} -> {sec1:.1f}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
