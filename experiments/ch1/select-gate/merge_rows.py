"""Replace rows of a localization-rows file by those of newer runs (the photos whose extracted skyline the
select gate changed; every other photo's skyline, and so its row, is the same to the bit).

``python experiments/ch1/select-gate/merge_rows.py BASE.json OUT.json NEW.json [NEW.json ...]``

BASE and OUT hold ``{"commit", "rows"}`` (``confidence-train-rows.json``) or ``{"photos": [...]}`` (a
``real_localize`` run); NEW are ``real_localize`` runs. Rows are matched on (photo, fov mode).
"""

from __future__ import annotations

import json
import sys


def main(base: str, out: str, news: list[str]) -> None:
    with open(base) as f:
        doc = json.load(f)
    key = "rows" if "rows" in doc else "photos"
    replaced = {}
    for path in news:
        with open(path) as f:
            new = json.load(f)
        for r in new["photos"]:
            replaced[r["photo"], r["fov_mode"]] = r
        commit = new.get("commit")
    rows = [replaced.pop((r["photo"], r["fov_mode"]), r) for r in doc[key]]
    if replaced:
        raise SystemExit(f"rows not in {base}: {sorted(replaced)}")
    doc[key] = rows
    doc["commit"] = f"{doc.get('commit')}; {len(news)} run(s) merged at {commit}"
    with open(out, "w") as f:
        json.dump(doc, f, **({} if key == "rows" else {"indent": 1}))
    print(f"{out}: {len(rows)} rows")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
