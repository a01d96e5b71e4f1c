"""Offline: does a second search with the fov unknown agree with the fov-given answer, and is an answer on which
the two agree right? Pairs each photo's fov-known row with its fov-unknown row (the same skyline, terrain and
preset: what ``LocalizeParams.second_opinion_from`` runs inside ``localize``, to the bit) and tables, for answers
the fov-given search withholds with a confidence of at least FLOOR, how many the two searches place within 1 km
of each other, and how many of those are right.

    python experiments/ch1/mode-agreement/agreement.py --known K.json --unknown U.json [U2.json ...] [--floors ...]
"""
import argparse
import json

import numpy as np

from skyrender.benchmarks.real_localize import split_places


def rows_of(path: str, mode: str) -> dict:
    data = json.load(open(path))
    rows = data.get("rows") or data.get("photos")
    return {r["photo"]: r for r in rows if r["fov_mode"] == mode}


def best_xy(row: dict) -> np.ndarray:
    """The answer's position: the best refined pose (the photo preset bounds no ground slope)."""
    poses = np.asarray(row["refined_poses"], float).reshape(-1, 8)
    return poses[np.argmin(poses[:, 7]), :2]


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--known", required=True)
    p.add_argument("--unknown", nargs="+", required=True)
    p.add_argument("--threshold", type=float, default=0.95, help="the fov-given answers' threshold")
    p.add_argument("--floors", type=float, nargs="+", default=[0.0, 0.2, 0.3, 0.4, 0.5, 0.6])
    p.add_argument("--agree-m", type=float, default=1000.0)
    p.add_argument("--list", action="store_true")
    a = p.parse_args()
    known = rows_of(a.known, "known")
    unknown = {}
    for path in a.unknown:
        unknown.update(rows_of(path, "unknown"))
    place_of = split_places()
    keys = [k for k in known if k in unknown]
    print(f"{len(keys)} photos with both rows ({len(known)} fov-known rows, {len(unknown)} fov-unknown rows)")
    recs = []
    for k in keys:
        rk, ru = known[k], unknown[k]
        xy, truth = best_xy(rk), np.asarray(rk["truth_xy"], float)
        apart = float(np.hypot(*(xy - best_xy(ru))))
        recs.append(dict(photo=k, place=place_of[k], conf=rk["confidence"], err=float(np.hypot(*(xy - truth))),
                         apart=apart, s_known=rk["seconds"], s_unknown=ru["seconds"]))
    conf = np.array([r["conf"] for r in recs])
    right = np.array([r["err"] <= 1000 for r in recs])
    agree = np.array([r["apart"] <= a.agree_m for r in recs])
    s_k = np.array([r["s_known"] for r in recs])
    s_u = np.array([r["s_unknown"] for r in recs])
    answered = conf >= a.threshold
    print(f"fov given alone: best place within 1 km {right.sum()}, answered at >= {a.threshold:.2f}: "
          f"{int((answered & right).sum())} right, {int((answered & ~right).sum())} wrong; median {np.median(s_k):.1f} s")
    print(f"both searches' best places within {a.agree_m:.0f} m of each other: {int((agree & right).sum())} right, "
          f"{int((agree & ~right).sum())} wrong (of {right.sum()} right, {(~right).sum()} wrong)")
    print("floor | second search run on | agree among them: right / wrong | answered then: right / wrong | "
          "median s (the second search's seconds added where run)")
    for f in a.floors:
        run = ~answered & (conf >= f)
        gain = run & agree
        secs = s_k + np.where(run, s_u, 0.0)
        print(f"{f:4.2f} | {int(run.sum())} | {int((gain & right).sum())} / {int((gain & ~right).sum())} | "
              f"{int(((answered | gain) & right).sum())} / {int(((answered | gain) & ~right).sum())} | "
              f"{np.median(secs):.1f}")
    if a.list:
        for r in sorted(recs, key=lambda r: -r["conf"]):
            print(f"  {r['photo']:34s} {r['place']:12s} conf {r['conf']:.2f} err {r['err']:8.0f} m "
                  f"apart {r['apart']:8.0f} m")


if __name__ == "__main__":
    main()
