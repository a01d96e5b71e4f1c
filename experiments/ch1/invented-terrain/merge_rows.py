"""Replace the rows of the photos in the windows that hold invented terrain (re-localized with the
model that puts no peak, viewpoint or far-horizon centre there) in a stored run's JSON (2026-12-05).

``python experiments/ch1/invented-terrain/merge_rows.py OLD.json NEW.json OUT.json [KEY]``: OLD's rows
(under KEY, "rows" or "photos") with those of NEW's photos and fov modes replaced by NEW's; the commit
field says which rows come from where. Prints, per replaced row, the error and scores before and after.
"""

from __future__ import annotations

import json
import sys


def main(old_path: str, new_path: str, out_path: str, key: str = "rows") -> None:
    with open(old_path) as f:
        old = json.load(f)
    with open(new_path) as f:
        new = json.load(f)
    fresh = {(r["photo"], r["fov_mode"]): r for r in new["photos"]}
    rows, replaced = [], 0
    for r in old[key]:
        n = fresh.get((r["photo"], r["fov_mode"]))
        if n is not None:
            replaced += 1
            before = r.get("error_m", r.get("withheld_error_m"))
            after = n.get("error_m", n.get("withheld_error_m"))
            print(f"{r['photo']:36s} {r['fov_mode']:7s} error {before:9.1f} -> {after:9.1f} m  best {r['best_score']:.4f} -> "
                  f"{n['best_score']:.4f}  runner-up {r['runner_up_score']:.4f} -> {n['runner_up_score']:.4f}")
        rows.append(n if n is not None else r)
    out = dict(old)
    out[key] = rows
    out["commit"] = f"{old.get('commit')} ({len(rows) - replaced} rows) + {new.get('commit')} ({replaced} rows: {new_path})"
    with open(out_path, "w") as f:
        json.dump(out, f)
    print(f"{replaced} of {len(rows)} rows replaced -> {out_path}")


if __name__ == "__main__":
    main(*sys.argv[1:])
