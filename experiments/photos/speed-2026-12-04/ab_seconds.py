"""Seconds of ``extract_skyline`` on a few photos, the code before a change against the change, in
alternating processes (this machine's timings drift by up to a third between runs): per photo the least
of ``--reps`` extractions in each process, then per code the median over photos of the least over its
processes.

``python experiments/photos/speed-2026-12-04/ab_seconds.py BEFORE_TREE AFTER_TREE [--method hybrid]
[--photos 8] [--rounds 3] [--reps 2]``
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np

CHILD = """
import json, sys, time
import numpy as np
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo
method, n, reps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
items = [it for it in items_on_side("dev") if it.key.startswith("ch1/")][:n]
images = [load_photo(it.image_path) for it in items]
extract_skyline(images[0], SkylineParams(method=method))
out = []
for image in images:
    best = np.inf
    for _ in range(reps):
        t = time.perf_counter()
        extract_skyline(image, SkylineParams(method=method))
        best = min(best, time.perf_counter() - t)
    out.append(best)
print(json.dumps(out))
"""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--method", default="hybrid")
    ap.add_argument("--photos", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--reps", type=int, default=2)
    args = ap.parse_args()
    seconds = {"before": [], "after": []}
    for _ in range(args.rounds):
        for label in ("before", "after"):
            tree = getattr(args, label)
            env = {**os.environ, "PYTHONPATH": tree}
            run = subprocess.run([sys.executable, "-c", CHILD, args.method, str(args.photos), str(args.reps)],
                                 env=env, capture_output=True, text=True, check=True, cwd=tree)
            seconds[label].append(json.loads(run.stdout.strip().splitlines()[-1]))
            print(label, " ".join(f"{s:.3f}" for s in seconds[label][-1]), flush=True)
    least = {k: np.min(np.array(v), axis=0) for k, v in seconds.items()}
    b, a = np.median(least["before"]), np.median(least["after"])
    print(f"{args.method}: median over {args.photos} CH1 dev photos of the least seconds: "
          f"before {b:.3f} s, after {a:.3f} s ({b / a:.2f}x)")


if __name__ == "__main__":
    main()
