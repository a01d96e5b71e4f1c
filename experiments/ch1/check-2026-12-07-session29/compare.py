"""The committed headline run against a run of the current code, row by row (photo and fov mode): refined poses the
same to the bit, status, error and confidence.

``git show 6133a7e:experiments/ch1/bench-real-validation.json > /tmp/before.json; python
experiments/ch1/check-2026-12-07-session29/compare.py /tmp/before.json experiments/ch1/bench-real-validation.json``
(the headline before: the rows made at 89f1da0 with the smaller EM budget; after: ``make bench-real`` at 6133a7e)
"""
import json
import sys

import numpy as np


def rows(path):
    with open(path) as f:
        return {(r["photo"], r["fov_mode"]): r for r in json.load(f)["photos"]}


before, after = rows(sys.argv[1]), rows(sys.argv[2])
keys = sorted(set(before) & set(after))
same_poses = sum(before[k]["refined_poses"] == after[k]["refined_poses"] for k in keys)
same_status = sum(before[k]["status"] == after[k]["status"] for k in keys)
dconf = np.array([abs(before[k]["confidence"] - after[k]["confidence"]) for k in keys])
print(f"{len(keys)} rows in both: refined poses the same to the bit {same_poses}, status the same {same_status}, "
      f"confidence moved by at most {dconf.max():.2e}")
for k in keys:
    b, a = before[k], after[k]
    if b["refined_poses"] != a["refined_poses"] or b["status"] != a["status"]:
        print(f"  {k[0]} {k[1]}: {b['status']} {b.get('error_m')} {b['confidence']:.3f} -> "
              f"{a['status']} {a.get('error_m')} {a['confidence']:.3f}")
for mode in ("known", "unknown"):
    sb = [before[k]["seconds"] for k in keys if k[1] == mode]
    sa = [after[k]["seconds"] for k in keys if k[1] == mode]
    print(f"fov {mode}: median seconds {np.median(sb):.1f} (committed) -> {np.median(sa):.1f} (this run)")
