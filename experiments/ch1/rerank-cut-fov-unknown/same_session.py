"""The previous code and this one on the same 10 validation photos, fov unknown, one after the other on one idle
machine in one session: the seconds side by side, and each photo's answer against the full validation runs.

``python experiments/ch1/rerank-cut-fov-unknown/same_session.py > experiments/ch1/rerank-cut-fov-unknown/same_session.txt``

The runs (``--limit 10``: spread over the places; ``--no-abstain``, so every photo's best place and confidence show):
``real_localize --side validation --fov unknown --limit 10 --no-abstain --tag same-session-6dc7fe9`` in a worktree at
6dc7fe9 (the preset before the cut: every far-horizon pose re-ranked), then ``--tag same-session-head`` at this
folder's shipped code. Each photo's error and confidence are also set beside its row in the full validation run of
that code (``../other-fov-runner-up/bench-real-validation-both.json`` at 0cf478f, ``bench-real-validation-cut300.json``
at 90f3842): the same, so the full runs' accuracy comparison holds though they ran in different sessions.
"""

import json
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def rows(path: str) -> dict:
    with open(path) as f:
        return {r["photo"]: r for r in json.load(f)["photos"]}


def best_error(row: dict) -> float:
    """Metres from the truth to the best-scoring refined pose: the answer, given or withheld."""
    poses = np.array(row["refined_poses"])
    return float(np.hypot(*(poses[np.argmin(poses[:, 7]), :2] - row["truth_xy"]))) if len(poses) else np.nan


def main() -> None:
    old, new = rows(os.path.join(HERE, "bench-real-validation-same-session-6dc7fe9.json")), \
        rows(os.path.join(HERE, "bench-real-validation-same-session-head.json"))
    full_old = rows(os.path.join(HERE, "../other-fov-runner-up/bench-real-validation-both.json"))
    full_new = rows(os.path.join(HERE, "bench-real-validation-cut300.json"))
    print(f"{'photo':30s} {'6dc7fe9 s':>9s} {'head s':>7s} {'ratio':>6s}   error m / confidence: 6dc7fe9 (its full run) | "
          "head (its full run)")
    same = 0
    for k in old:
        o, n, fo, fn = old[k], new[k], full_old[k], full_new[k]
        eo, en = best_error(o), best_error(n)
        match = (np.allclose(o["refined_poses"], fo["refined_poses"]) and np.allclose(n["refined_poses"], fn["refined_poses"]))
        same += match
        print(f"{k[4:30]:30s} {o['seconds']:9.1f} {n['seconds']:7.1f} {n['seconds'] / o['seconds']:6.2f}   "
              f"{eo:8.0f} {o['confidence']:.2f} ({best_error(fo):.0f} {fo['confidence']:.2f}) | "
              f"{en:8.0f} {n['confidence']:.2f} ({best_error(fn):.0f} {fn['confidence']:.2f})"
              f"{'' if match else '  refined poses differ from the full run'}")
    so, sn = np.array([old[k]["seconds"] for k in old]), np.array([new[k]["seconds"] for k in old])
    print(f"\nmedian seconds: 6dc7fe9 {np.median(so):.1f}, head {np.median(sn):.1f}; median ratio {np.median(sn / so):.2f}, "
          f"total {sn.sum():.0f} / {so.sum():.0f} s = {sn.sum() / so.sum():.2f}; refined poses as in the full runs: "
          f"{same} of {len(old)} photos")


if __name__ == "__main__":
    main()
