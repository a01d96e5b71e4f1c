"""Which training-side photos does the localizer get wrong? Those whose skyline is near (a probe, 2026-12-05).

``python experiments/ch1/near-skylines/by_distance.py ORACLE.json [ORACLE.json ...] [--rows ROWS.json]``

Joins ``skyrender.diagnostics.oracle`` rows (the best fit at the true position, with the distance of the
terrain forming each skyline column) to the localization rows the photo confidence is fitted on
(``experiments/ch1/confidence-train-rows.json``: fov known, no abstention; ``--rows``: a ``real_localize`` run's
JSON, its fov-known rows) and compares, for answers within
1 km and beyond, the share of skyline columns formed by terrain nearer than 1 km and 3 km, and the oracle's
median residual.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

from skyrender.datasets.real_photos import REPO

ROWS = os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")


def near_share(by_distance: dict, bins: tuple[str, ...]) -> float:
    total = sum(v["columns"] for v in by_distance.values())
    return sum(v["columns"] for k, v in by_distance.items() if k in bins) / max(total, 1)


def main(paths: list[str], rows: str = ROWS) -> None:
    doc = json.load(open(rows))
    verdicts = {r["photo"]: r for r in doc.get("rows", doc.get("photos", [])) if r.get("fov_mode", "known") == "known"}
    oracle = [o for p in paths for o in json.load(open(p)) if o["photo"] in verdicts]
    groups = {"answered within 1 km (conf >= 0.90)": [], "withheld within 1 km": [], "beyond 1 km": []}
    for o in oracle:
        r = verdicts[o["photo"]]
        r["error_m"] = r.get("error_m", r.get("withheld_error_m", np.inf))
        answered = "withheld_error_m" not in r and r["confidence"] >= 0.9
        key = ("beyond 1 km" if r["error_m"] > 1000 else
               "answered within 1 km (conf >= 0.90)" if answered else "withheld within 1 km")
        groups[key].append((near_share(o["by_distance"], ("0-1 km",)),
                            near_share(o["by_distance"], ("0-1 km", "1-3 km")), o["median_px"], o["photo"]))
    print(f"{len(oracle)} photos (oracle rows joined to the localization rows of {os.path.relpath(rows, REPO)})\n")
    print(f"{'':38s} {'n':>3s}  {'< 1 km, median':>15s}  {'< 3 km, median':>15s}  {'< 3 km > 50 %':>14s}  {'oracle px':>9s}")
    for key, g in groups.items():
        a = np.array([x[:3] for x in g]) if g else np.zeros((0, 3))
        print(f"{key:38s} {len(g):3d}  {np.median(a[:, 0]) * 100:14.0f}%  {np.median(a[:, 1]) * 100:14.0f}%  "
              f"{np.sum(a[:, 1] > 0.5):14d}  {np.median(a[:, 2]):9.2f}")
    print("\nbeyond 1 km, by share of columns nearer than 3 km:")
    for s1, s3, px, photo in sorted(groups["beyond 1 km"], key=lambda x: -x[1]):
        print(f"  {photo:36s} < 1 km {100 * s1:5.1f} %  < 3 km {100 * s3:5.1f} %  oracle {px:5.2f} px  "
              f"error {verdicts[photo]['error_m'] / 1000:6.1f} km")


if __name__ == "__main__":
    args = sys.argv[1:]
    if "--rows" in args:
        i = args.index("--rows")
        main(args[:i] + args[i + 2:], os.path.abspath(args[i + 1]))
    else:
        main(args)
