"""The compiled alignment's runs against the previous code's: ``python experiments/ch1/compiled-alignment/compare.py >
experiments/ch1/compiled-alignment/compare.txt``.

1. The 10 validation photos both codes ran one after the other (fov unknown, ``--no-abstain``): seconds side by
   side, and whether every refined pose (position, orientation, focal length, score) is the same to the bit.
2. The full ``make bench-real`` run at this code against the previous full runs, photo by photo: fov known against
   ``../bench-real-validation.json`` (525fc5c), fov unknown against
   ``../rerank-cut-fov-unknown/bench-real-validation-cut300.json`` (90f3842, rescored with the fit shipped since,
   whose logit and thresholds the shipped ``photo_confidence.json`` has): refined poses, status and confidence.
"""

import json
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def rows(path: str, mode: str | None = None) -> dict:
    with open(os.path.join(HERE, path)) as f:
        return {r["photo"]: r for r in json.load(f)["photos"] if mode is None or r["fov_mode"] == mode}


def same_poses(a: dict, b: dict) -> bool:
    return np.array_equal(np.array(a["refined_poses"], float), np.array(b["refined_poses"], float))


def same_session() -> None:
    old, new = rows("bench-real-validation-same-session-11e3c8c.json"), rows("bench-real-validation-same-session-head.json")
    print("1. The same 10 validation photos, fov unknown, the previous code (11e3c8c) then this one, one session")
    print(f"{'photo':30s} {'11e3c8c s':>9s} {'head s':>7s} {'ratio':>6s}  refined poses and confidence")
    same = 0
    for k in old:
        o, n = old[k], new[k]
        match = same_poses(o, n) and o["confidence"] == n["confidence"] and o["status"] == n["status"]
        same += match
        print(f"{k[4:30]:30s} {o['seconds']:9.1f} {n['seconds']:7.1f} {n['seconds'] / o['seconds']:6.2f}  "
              f"{'the same to the bit' if match else 'DIFFER'}")
    so, sn = np.array([old[k]["seconds"] for k in old]), np.array([new[k]["seconds"] for k in old])
    print(f"median seconds: 11e3c8c {np.median(so):.1f}, head {np.median(sn):.1f}; median ratio {np.median(sn / so):.2f}; "
          f"total {sn.sum():.0f} / {so.sum():.0f} s = {sn.sum() / so.sum():.2f}; the same: {same} of {len(old)} photos\n")


def full_run() -> None:
    print("2. make bench-real at this code against the previous full runs, every photo")
    for mode, previous in (("known", "../bench-real-validation.json"),
                           ("unknown", "../rerank-cut-fov-unknown/bench-real-validation-cut300.json")):
        now, before = rows("bench-real-validation.json", mode), rows(previous, mode)
        poses = sum(same_poses(now[k], before[k]) for k in now)
        status = sum(now[k]["status"] == before[k]["status"] for k in now)
        confidence = sum(abs(now[k]["confidence"] - before[k]["confidence"]) < 1e-9 for k in now)
        sn, sb = np.array([now[k]["seconds"] for k in now]), np.array([before[k]["seconds"] for k in now])
        print(f"fov {mode:7s}: {len(now)} photos; refined poses the same to the bit {poses}, status {status}, "
              f"confidence {confidence}; median seconds {np.median(sb):.1f} (previous run) -> {np.median(sn):.1f}")
        for k in now:
            if not (same_poses(now[k], before[k]) and now[k]["status"] == before[k]["status"]):
                print(f"  {k}: {before[k]['status']} {before[k]['confidence']:.3f} -> {now[k]['status']} "
                      f"{now[k]['confidence']:.3f}")


if __name__ == "__main__":
    same_session()
    if os.path.exists(os.path.join(HERE, "bench-real-validation.json")):
        full_run()
