"""``select``'s seconds, the code before against this code, photo by photo and moments apart: two worker processes (one
on a worktree of the commit before, one on this checkout) take turns on each photo, the turn order alternating, each
extraction repeated and its least seconds kept. A machine whose speed drifts over minutes (this one's did, by a
third) then moves both sides of each pair alike.

    python experiments/photos/float32-densities/paired_speed.py --before-path /work/before [--sides validation]
        [--only-ch1] [--repeats 3] [--out paired.json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np

WORKER = r"""
import hashlib, json, sys, time
import numpy as np
from skyrender.evaluate import git_commit
from skyrender.features import SkylineParams, extract_skyline, load_photo
params = SkylineParams(method="select")
print(json.dumps({"commit": git_commit()}), flush=True)
for line in sys.stdin:
    job = json.loads(line)
    image = load_photo(job["path"])
    times = []
    for _ in range(job["repeats"]):
        t = time.perf_counter()
        result = extract_skyline(image, params)
        times.append(time.perf_counter() - t)
    digest = hashlib.sha1(np.ascontiguousarray(result.skyline).tobytes()).hexdigest()
    print(json.dumps({"seconds": min(times), "skyline_sha1": digest}), flush=True)
"""


def start(pythonpath: str | None) -> tuple[subprocess.Popen, str]:
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    proc = subprocess.Popen([sys.executable, "-c", WORKER], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            env=env, cwd=pythonpath or None)
    return proc, json.loads(proc.stdout.readline())["commit"]


def ask(proc: subprocess.Popen, path: str, repeats: int) -> dict:
    proc.stdin.write(json.dumps({"path": path, "repeats": repeats}) + "\n")
    proc.stdin.flush()
    return json.loads(proc.stdout.readline())


def main(argv=None) -> int:
    from skyrender.datasets.real_photos import items_on_side

    ap = argparse.ArgumentParser()
    ap.add_argument("--before-path", required=True, help="a checkout of the commit before (a git worktree)")
    ap.add_argument("--sides", nargs="+", default=["validation"])
    ap.add_argument("--only-ch1", action="store_true")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    items = [it for side in args.sides for it in items_on_side(side) if not args.only_ch1 or it.key.startswith("ch1/")]
    workers = {"before": start(args.before_path), "after": start(None)}
    for name in workers:  # warm-up: numba's kernels, the network
        ask(workers[name][0], items[0].image_path, 1)
    rows = []
    for k, it in enumerate(items):
        order = ["before", "after"] if k % 2 == 0 else ["after", "before"]
        got = {name: ask(workers[name][0], it.image_path, args.repeats) for name in order}
        rows.append({"photo": it.key, **{f"seconds_{n}": got[n]["seconds"] for n in got},
                     "same_skyline": got["before"]["skyline_sha1"] == got["after"]["skyline_sha1"]})
        print(f"{it.key}: {got['before']['seconds']:.3f} -> {got['after']['seconds']:.3f} s"
              f"{'' if rows[-1]['same_skyline'] else ' (skyline differs)'}", flush=True)
    for proc, _ in workers.values():
        proc.stdin.close()
        proc.wait()
    b = np.array([r["seconds_before"] for r in rows])
    a = np.array([r["seconds_after"] for r in rows])
    summary = {"before": workers["before"][1], "after": workers["after"][1], "photos": len(rows),
               "repeats": args.repeats, "same_skylines": sum(r["same_skyline"] for r in rows),
               "median_before": float(np.median(b)), "median_after": float(np.median(a)),
               "median_ratio": float(np.median(a / b))}
    print(json.dumps(summary))
    if args.out:
        with open(args.out, "w") as f:
            json.dump({**summary, "rows": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
