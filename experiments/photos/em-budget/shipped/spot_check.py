"""The validation rows localized again at 825eec0 (``bench-real-validation-spot.*``) against the em-budget rows that
``experiments/ch1/bench-real-validation.*`` holds: every field that depends on the search, to the bit.

``python experiments/photos/em-budget/shipped/spot_check.py > experiments/photos/em-budget/shipped/spot-check.txt``
after ``python -m skyrender.benchmarks.real_localize --side validation --photos ch1/dsc02494_01024
ch1/04032011391_01024 ch1/dsc05274_01024 --tag spot --out <this folder>``.
"""

import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
KEYS = ["status", "confidence", "refined_poses", "best_score", "runner_up_score", "pose", "fov", "second_opinion",
        "error_m"]

spot = json.load(open(os.path.join(HERE, "bench-real-validation-spot.json")))
ref = {}
for tag in ("", "-unknown"):
    for r in json.load(open(os.path.join(HERE, "..", "localize", f"bench-real-validation-em-budget{tag}.json")))["photos"]:
        ref[(r["photo"], r["fov_mode"])] = r
print(f"commit {spot['commit']} against the em-budget rows (89f1da0 with em-budget.patch)")
for r in spot["photos"]:
    o = ref[(r["photo"], r["fov_mode"])]
    diff = [k for k in KEYS if r.get(k) != o.get(k)]
    print(f"{r['photo']:26s} {r['fov_mode']:8s} {'the same to the bit' if not diff else 'differs in ' + ', '.join(diff)}"
          f" ({r['seconds']:.1f} s against {o['seconds']:.1f} s)")
