"""The validation and held-out photos' skylines with the 12,000-step network beside the 4,000-step one, per
photo: two ``make bench-skyline`` runs of the same extractor code, the previous read from git.

``python experiments/photos/net-12k/validation_against_previous.py [PREVIOUS_COMMIT]`` (default cf5c88d: its file is
the run of commit 2c7d97b, the last with the 4,000-step network) -> ``validation-against-previous.txt`` beside this file.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

from skyrender.benchmarks.skyline_photos import meets_target

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = "experiments/photos/bench-skyline.json"
METHODS = ("select", "hybrid", "net")


def main(previous: str = "cf5c88d") -> None:
    root = subprocess.check_output(["git", "rev-parse", "--show-toplevel"], cwd=HERE, text=True).strip()
    before = json.loads(subprocess.check_output(["git", "show", f"{previous}:{BENCH}"], cwd=root))
    with open(os.path.join(root, BENCH)) as f:
        after = json.load(f)
    lines = [f"{BENCH}: {before['commit']} (4,000-step network) against {after['commit']} (12,000 steps); share within 5 px, "
             "* = target met"]
    for side in ("validation", "heldout"):
        old = {p["photo"]: p for p in before["sides"][side]["photos"]}
        lines.append(f"\n{side}\n{'photo':34s} " + " ".join(f"{m:>17s}" for m in METHODS))
        up = down = 0
        for p in after["sides"][side]["photos"]:
            cells = []
            for m in METHODS:
                a, b = old[p["photo"]][m], p[m]
                marks = ["*" if meets_target(r["median"], r["within5"]) else " " for r in (a, b)]
                cells.append(f"{100 * a['within5']:5.1f}{marks[0]} -> {100 * b['within5']:5.1f}{marks[1]}")
            change = p["select"]["within5"] - old[p["photo"]]["select"]["within5"]
            up, down = up + (change > 0.01), down + (change < -0.01)
            lines.append(f"{p['photo']:34s} " + " ".join(f"{c:>17s}" for c in cells) + ("  <-" if abs(change) > 0.01 else ""))
        for m in METHODS:
            s0, s1 = before["sides"][side]["summary"][m], after["sides"][side]["summary"][m]
            lines.append(f"{m}: met {s0['met']} -> {s1['met']} of {s1['photos']}, mean within 5 px "
                         f"{100 * s0['mean_within5']:.1f} -> {100 * s1['mean_within5']:.1f} %")
        lines.append(f"select better by more than a point on {up} photos, worse on {down} (<-)")
    with open(os.path.join(HERE, "validation-against-previous.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(*sys.argv[1:2])
