"""Which stored CH1 answers and refined poses stand on invented terrain (2026-12-05).

``python experiments/ch1/invented-terrain/on_invented.py ROWS.json ...``: for every row (``rows`` or ``photos``) whose
DEM window holds invented terrain (``DEM.invented``: the windows reaching into the missing N45E008-N45E010 tiles), the
answer's error and whether it, and how many of its refined poses, stand there.
"""

from __future__ import annotations

import glob
import json
import sys

import numpy as np

from skyrender.dem import load_dem

TILES = sorted(glob.glob("../shared/data/dem/N4*.hgt"))


def main(paths: list[str]) -> None:
    dems = {}
    for path in paths:
        with open(path) as f:
            d = json.load(f)
        rows = d.get("rows") or d.get("photos")
        answers = poses = on_rows = 0
        for r in rows:
            window = tuple(round(float(v), 4) for v in r["window"])
            if window not in dems:
                dems[window] = load_dem(TILES, bounds=window)
            dem = dems[window]
            if dem.invented is None:
                continue
            refined = np.array(r["refined_poses"])
            on = dem.is_invented(refined[:, 0], refined[:, 1])
            answer = bool(dem.is_invented(r["pose"][0], r["pose"][1]))
            answers += answer
            poses += int(on.sum())
            on_rows += 1
            if answer or on.any():
                err = r.get("error_m", r.get("withheld_error_m"))
                print(f"  {r['photo']:36s} {r['fov_mode']:7s} error {err:9.0f} m  answer on invented terrain: {answer}; "
                      f"refined poses there: {int(on.sum())} of {len(refined)}")
        print(f"{path}: {on_rows} rows in windows with invented terrain; {answers} answers and {poses} refined poses stand on it")


if __name__ == "__main__":
    main(sys.argv[1:])
