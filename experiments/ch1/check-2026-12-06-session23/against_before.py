"""A bench-real run beside an earlier one, row by row: how many rows have the same status, confidence, error, refined
poses and second-opinion place, to the bit; the rows that differ; and the median seconds of each mode in each run.

    python experiments/ch1/check-2026-12-06-session23/against_before.py NEW.json BEFORE.json
"""

from __future__ import annotations

import json
import sys

import numpy as np

FIELDS = ("status", "confidence", "error_m", "refined_poses", "best_score", "runner_up_score")


def rows(path: str) -> dict:
    with open(path) as f:
        return {(r["photo"], r["fov_mode"]): r for r in json.load(f)["photos"]}


def second_place(row: dict):
    return (row.get("second_opinion") or {}).get("pose")


def main(new_path: str, before_path: str) -> None:
    new, before = rows(new_path), rows(before_path)
    for mode in sorted({m for _, m in new}):
        keys = sorted(k for k in new if k[1] == mode)
        differ = [k for k in keys if any(new[k].get(f) != before[k].get(f) for f in FIELDS)
                  or second_place(new[k]) != second_place(before[k])]
        seconds = [np.median([rows_[k]["seconds"] for k in keys]) for rows_ in (new, before)]
        print(f"fov {mode}: {len(keys) - len(differ)} of {len(keys)} rows the same to the bit (status, confidence, "
              f"error, refined poses, scores, second opinion's place); median seconds {seconds[0]:.1f} now, "
              f"{seconds[1]:.1f} before")
        for k in differ:
            fields = [f for f in FIELDS if new[k].get(f) != before[k].get(f)]
            print(f"  {k[0]}: differs in {', '.join(fields) or 'the second opinion'}: {before[k]['status']} "
                  f"{before[k].get('error_m')} {before[k]['confidence']:.3f} -> {new[k]['status']} {new[k].get('error_m')} "
                  f"{new[k]['confidence']:.3f}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
