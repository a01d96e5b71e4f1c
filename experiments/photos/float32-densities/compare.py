"""Two runs of ``extract_all.py`` (the code before and after a change) compared photo by photo: the skylines and
column confidences to the bit, and the seconds (each photo's least over the runs given of each code, which were
alternated on one machine).

    python experiments/photos/float32-densities/compare.py --before B1.npz [B2.npz ...] --after A1.npz [A2.npz ...]
        [--json ROWS.json]
"""

from __future__ import annotations

import argparse
import json

import numpy as np


def load(path: str) -> dict:
    z = np.load(path)
    n = len(z["keys"])
    return {"keys": list(z["keys"]), "widths": z["widths"], "seconds": z["seconds"], "commit": str(z["commit"]),
            "skylines": [z[f"skyline:{i}"] for i in range(n)], "confidences": [z[f"confidence:{i}"] for i in range(n)]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", nargs="+", required=True)
    ap.add_argument("--after", nargs="+", required=True)
    ap.add_argument("--json", help="also write the rows (photo, width, seconds of every run, the same or not) here")
    args = ap.parse_args(argv)
    before, after = [load(p) for p in args.before], [load(p) for p in args.after]
    a, b = before[0], after[0]
    assert a["keys"] == b["keys"], "the runs extracted different photos"
    same_skyline = [np.array_equal(x, y, equal_nan=True) for x, y in zip(a["skylines"], b["skylines"])]
    same_confidence = [np.array_equal(x, y) for x, y in zip(a["confidences"], b["confidences"])]
    for first, runs in ((a, before[1:]), (b, after[1:])):  # every run of one code gives the lines of its first
        for run in runs:
            assert all(np.array_equal(x, y, equal_nan=True) for x, y in zip(run["skylines"], first["skylines"])), \
                "one code's runs differ"
    t_before = np.min([r["seconds"] for r in before], axis=0)
    t_after = np.min([r["seconds"] for r in after], axis=0)
    print(f"before {a['commit']} ({len(before)} runs), after {b['commit']} ({len(after)} runs); {len(a['keys'])} photos")
    for k, key in enumerate(a["keys"]):
        if not (same_skyline[k] and same_confidence[k]):
            moved = np.abs(np.nan_to_num(a["skylines"][k], nan=-1e3) - np.nan_to_num(b["skylines"][k], nan=-1e3))
            print(f"  {key}: skyline {'same' if same_skyline[k] else f'{int((moved > 0).sum())} columns moved'}, "
                  f"confidence max change {np.abs(a['confidences'][k] - b['confidences'][k]).max():.1e}")
    print(f"skylines the same to the bit: {sum(same_skyline)} of {len(same_skyline)}; "
          f"confidences: {sum(same_confidence)} of {len(same_confidence)}")
    for name, pick in (("all", np.ones(len(a["keys"]), bool)), ("1,024 wide", a["widths"] == 1024),
                       ("validation", np.array([k.startswith("validation:") for k in a["keys"]]))):
        if not pick.any():
            continue
        tb, ta = t_before[pick], t_after[pick]
        print(f"{name} ({pick.sum()} photos): seconds median {np.median(tb):.3f} -> {np.median(ta):.3f}, "
              f"ratio median {np.median(ta / tb):.2f}")
    if args.json:
        rows = [{"photo": key, "width": int(a["widths"][k]), "skyline_same": same_skyline[k],
                 "confidence_same": same_confidence[k],
                 "max_confidence_change": float(np.abs(a["confidences"][k] - b["confidences"][k]).max()),
                 "seconds_before": [float(r["seconds"][k]) for r in before],
                 "seconds_after": [float(r["seconds"][k]) for r in after]} for k, key in enumerate(a["keys"])]
        with open(args.json, "w") as f:
            json.dump({"before": a["commit"], "after": b["commit"], "rows": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
