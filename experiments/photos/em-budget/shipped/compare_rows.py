"""Two bench-real runs of the same photos: the best refined place within 1 km in each, and the photos whose verdict or
confidence (by more than 0.05) moved.

``python experiments/photos/em-budget/shipped/compare_rows.py BEFORE.json AFTER.json``
"""

import json
import sys

import numpy as np


def rows(path: str) -> dict:
    with open(path) as f:
        return {r["photo"]: r for r in json.load(f)["photos"]}


def best_place_error(row: dict) -> float:
    """m from the truth to the best-scoring refined pose."""
    poses = np.asarray(row["refined_poses"])
    best = poses[np.argmin(poses[:, 7])]
    return float(np.hypot(*(best[:2] - np.asarray(row["truth_xy"]))))


def main() -> None:
    before, after = rows(sys.argv[1]), rows(sys.argv[2])
    photos = sorted(set(before) & set(after))
    same = sum(before[k]["refined_poses"] == after[k]["refined_poses"] for k in photos)
    within = [sum(best_place_error(run[k]) <= 1000 for k in photos) for run in (before, after)]
    print(f"{len(photos)} photos: best place within 1 km {within[0]} -> {within[1]}; "
          f"the same refined poses to the bit on {same}")
    for k in photos:
        ea, eb = best_place_error(before[k]), best_place_error(after[k])
        ca, cb = before[k]["confidence"], after[k]["confidence"]
        if (ea <= 1000) != (eb <= 1000) or abs(ca - cb) > 0.05:
            print(f"  {k:34s} best place {ea:8.0f} m -> {eb:8.0f} m, confidence {ca:.2f} -> {cb:.2f}")


if __name__ == "__main__":
    main()
