"""Two bench-real runs of the same photos, row by row (photo and fov mode): the best refined place within 1 km in each,
how many rows keep their refined poses to the bit and their status, the largest confidence change, the median
seconds per fov mode, and the rows whose verdict or confidence (by more than 0.05) moved.

``python experiments/photos/em-budget/shipped/compare_rows.py BEFORE.json AFTER.json``
"""

import json
import sys

import numpy as np

from skyrender.benchmarks.real_localize import answer_xy


def rows(path: str) -> dict:
    with open(path) as f:
        return {(r["photo"], r.get("fov_mode")): r for r in json.load(f)["photos"]}


def best_place_error(row: dict) -> float:
    """m from the truth to the best-scoring refined pose (the row's answer, given or withheld)."""
    return float(np.hypot(*(answer_xy(row) - np.asarray(row["truth_xy"]))))


def main() -> None:
    before, after = rows(sys.argv[1]), rows(sys.argv[2])
    keys = sorted(set(before) & set(after), key=lambda k: (k[0], str(k[1])))
    same = sum(before[k]["refined_poses"] == after[k]["refined_poses"] for k in keys)
    status = sum(before[k]["status"] == after[k]["status"] for k in keys)
    moved = max(abs(before[k]["confidence"] - after[k]["confidence"]) for k in keys)
    within = [sum(best_place_error(run[k]) <= 1000 for k in keys) for run in (before, after)]
    print(f"{len(keys)} rows: best place within 1 km {within[0]} -> {within[1]}; "
          f"the same refined poses to the bit on {same}, the same status on {status}; confidence moved by at most {moved:.2e}")
    for mode in sorted({k[1] for k in keys}, key=str):
        seconds = [np.median([run[k]["seconds"] for k in keys if k[1] == mode]) for run in (before, after)]
        print(f"fov {mode}: median seconds {seconds[0]:.1f} -> {seconds[1]:.1f}")
    for k in keys:
        ea, eb = best_place_error(before[k]), best_place_error(after[k])
        ca, cb = before[k]["confidence"], after[k]["confidence"]
        if (ea <= 1000) != (eb <= 1000) or abs(ca - cb) > 0.05 or before[k]["status"] != after[k]["status"]:
            print(f"  {k[0]:34s} {k[1]} best place {ea:8.0f} m -> {eb:8.0f} m, confidence {ca:.2f} -> {cb:.2f}, "
                  f"{before[k]['status']} -> {after[k]['status']}")


if __name__ == "__main__":
    main()
