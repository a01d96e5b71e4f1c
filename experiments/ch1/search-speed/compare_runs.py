"""This commit's ``make bench-real`` rows against the runs the README showed before (the fov known at 4179bb5,
rescored; the fov unknown at 4b5e86b), photo by photo: the same refined poses, status and confidence, and the
seconds.

``python experiments/ch1/search-speed/compare_runs.py experiments/ch1/bench-real-validation.json
> experiments/ch1/search-speed/compare-validation.txt``
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
BEFORE = {"known": os.path.join(HERE, "..", "dem-window", "validation", "bench-real-validation-dem-window.json"),
          "unknown": os.path.join(HERE, "..", "dem-window", "validation-unknown",
                                  "bench-real-validation-dem-window-unknown.json")}


def main() -> None:
    with open(sys.argv[1]) as f:
        now = json.load(f)
    print(f"now: {sys.argv[1]} at {now['commit']}")
    for mode, path in BEFORE.items():
        with open(path) as f:
            before = json.load(f)
        old = {r["photo"]: r for r in before["photos"] if r["fov_mode"] == mode}
        new = {r["photo"]: r for r in now["photos"] if r["fov_mode"] == mode}
        common = sorted(set(old) & set(new))
        same_poses = [p for p in common if old[p]["refined_poses"] == new[p]["refined_poses"]]
        # the fov-known run before was made without abstaining and rescored: its abstentions keep their pose
        same_answer = [p for p in common if old[p]["status"] == new[p]["status"]
                       and old[p]["confidence"] == new[p]["confidence"]
                       and (new[p]["status"] != "localized" or old[p]["pose"] == new[p]["pose"])]
        s_old = np.array([old[p]["seconds"] for p in common])
        s_new = np.array([new[p]["seconds"] for p in common])
        stages = sorted({k for p in common for k in new[p]["stage_seconds"]} | {k for p in common
                                                                                  for k in old[p]["stage_seconds"]})
        print(f"\nfov {mode}: {len(common)} photos in both (before: {before['commit']})")
        print(f"  refined poses the same to the bit: {len(same_poses)}; status, confidence and answer the same: "
              f"{len(same_answer)}")
        for p in common:
            if p not in same_poses or p not in same_answer:
                print(f"    differs: {p}")
        print(f"  median seconds (skyline included): before {np.median(s_old):.1f}, now {np.median(s_new):.1f} "
              f"(ratio of medians {np.median(s_old) / np.median(s_new):.2f}; per photo median ratio "
              f"{np.median(s_old / s_new):.2f})")
        for k in stages:
            a = np.median([old[p]["stage_seconds"].get(k, 0.0) for p in common])
            b = np.median([new[p]["stage_seconds"].get(k, 0.0) for p in common])
            if max(a, b) >= 0.05:
                print(f"    {k:16s} median {a:6.2f} -> {b:6.2f} s")


if __name__ == "__main__":
    main()
