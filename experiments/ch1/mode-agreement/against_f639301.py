"""A `make bench-real` run against f639301's (experiments/ch1/compiled-alignment/bench-real-validation.json): per fov
mode, how many refined poses are the same to the bit, the photos whose status or confidence moved, the median seconds.

    python experiments/ch1/mode-agreement/against_f639301.py experiments/ch1/bench-real-validation.json
"""
import json
import sys

import numpy as np

old = json.load(open("experiments/ch1/compiled-alignment/bench-real-validation.json"))["photos"]
new = json.load(open(sys.argv[1]))
print(f"{sys.argv[1]} (commit {new['commit']}) against f639301's run, 60 validation photos:")
for mode in ("known", "unknown"):
    o = {r["photo"]: r for r in old if r["fov_mode"] == mode}
    rows = [r for r in new["photos"] if r["fov_mode"] == mode]
    same = sum(np.array_equal(np.array(r["refined_poses"]), np.array(o[r["photo"]]["refined_poses"])) for r in rows)
    moved = [(r["photo"], o[r["photo"]]["status"], r["status"], round(o[r["photo"]]["confidence"], 4), round(r["confidence"], 4))
             for r in rows if r["status"] != o[r["photo"]]["status"] or r["confidence"] != o[r["photo"]]["confidence"]]
    seconds, before = np.median([r["seconds"] for r in rows]), np.median([r["seconds"] for r in o.values()])
    print(f"  fov {mode}: refined poses the same to the bit {same} of {len(rows)}; status or confidence moved: {moved}; "
          f"median seconds {seconds:.1f} (f639301 {before:.1f})")
