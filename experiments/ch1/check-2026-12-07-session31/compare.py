"""A bench-real run against the committed one, row by row: the same answers (pose, status, confidence) or not, and
the seconds. ``python experiments/ch1/check-2026-12-07-session31/compare.py OLD.json NEW.json [--fov known]``"""
import json
import sys

import numpy as np

old_path, new_path = sys.argv[1], sys.argv[2]
fov = sys.argv[sys.argv.index("--fov") + 1] if "--fov" in sys.argv else "known"
old, new = (json.load(open(p)) for p in (old_path, new_path))
old_rows = {r["photo"]: r for r in old["photos"] if r["fov_mode"] == fov}
new_rows = [r for r in new["photos"] if r["fov_mode"] == fov]
same = 0


def metres(row: dict) -> str:
    return "-" if row.get("error_m") is None else f"{row['error_m']:.0f}"


print(f"{old['commit']} -> {new['commit']}, fov {fov}, {len(new_rows)} photos")
print(f"{'photo':34s} {'status':>22s} {'error m':>19s} {'confidence':>13s} {'seconds':>13s}  same answer")
for r in new_rows:
    o = old_rows[r["photo"]]
    alike = all(r.get(k) == o.get(k) for k in ("status", "pose", "error_m", "confidence", "refined_poses"))
    same += alike
    print(f"{r['photo']:34s} {o['status']:>10s} {r['status']:>11s} {metres(o):>9s} {metres(r):>9s} "
          f"{o['confidence']:6.3f} {r['confidence']:6.3f} {o['seconds']:6.1f} {r['seconds']:6.1f}  {'yes' if alike else 'NO'}")
so, sn = np.median([old_rows[r["photo"]]["seconds"] for r in new_rows]), np.median([r["seconds"] for r in new_rows])
print(f"\nthe same answer (status, pose, error, confidence and every refined pose, to the last digit) on {same} of "
      f"{len(new_rows)}; median seconds {so:.1f} -> {sn:.1f}")
