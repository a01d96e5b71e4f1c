"""A probe's training-side rows beside the shipped preset's (``../rerank-all/``): the photos over 1 km wrong in either,
with how many refined poses lie within 1 km of the truth, and the photos won and lost.
``python experiments/ch1/in-list/compare.py DIR TAG`` (rows DIR/bench-real-{train,dev}-TAG.json)."""
import json
import sys

import numpy as np


def known_rows(path: str) -> dict:
    with open(path) as f:
        return {r["photo"]: r for r in json.load(f)["photos"] if r["fov_mode"] == "known"}


def refined_within_1km(row: dict) -> int:
    truth, refined = np.array(row["truth_xy"]), np.array(row["refined_poses"])
    return int((np.hypot(refined[:, 0] - truth[0], refined[:, 1] - truth[1]) < 1000).sum())


def main(folder: str, tag: str) -> None:
    old, new = {}, {}
    for side in ("train", "dev"):
        old.update(known_rows(f"experiments/ch1/rerank-all/bench-real-{side}-rerank-all.json"))
        new.update(known_rows(f"{folder}/bench-real-{side}-{tag}.json"))
    won = lost = 0
    for key, n in new.items():
        o = old[key]
        flag = "" if (n["error_m"] > 1000) == (o["error_m"] > 1000) else ("WON" if n["error_m"] <= 1000 else "LOST")
        won, lost = won + (flag == "WON"), lost + (flag == "LOST")
        if flag or n["error_m"] > 1000:
            print(f"{key:35s} {o['error_m']:8.0f} near {refined_within_1km(o)} -> {n['error_m']:8.0f} "
                  f"near {refined_within_1km(n)} {flag}")
    print(f"photos {len(new)}, within 1 km: before {sum(old[k]['error_m'] <= 1000 for k in new)}, "
          f"now {sum(n['error_m'] <= 1000 for n in new.values())}; won {won}, lost {lost}")
    print(f"median seconds: before {np.median([old[k]['seconds'] for k in new]):.1f}, "
          f"now {np.median([n['seconds'] for n in new.values()]):.1f}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
