"""How much of the answer's and the runner-up's skyline is invented terrain (2026-12-05, session 12).

``python experiments/ch1/invented-terrain/runner_up_views.py ROWS.json ...``: for every row whose DEM window holds
invented terrain (the windows reaching into the missing N45E008-N45E010 tiles), the answer and its runner-up (the
best refined pose more than ``PHOTO_RUNNER_UP_M`` away, as the confidence takes it) are rendered with each column's
terrain distance, and the share of their skyline columns whose terrain stands on invented cells is printed
(``datasets.synthetic.invented_skyline_share``), with the row's error, confidence and scores.
"""

from __future__ import annotations

import csv
import glob
import json
import sys

import numpy as np

from skyrender.camera import Intrinsics, Pose
from skyrender.datasets.synthetic import invented_skyline_share
from skyrender.dem import load_dem
from skyrender.localizer.confidence import PHOTO_RUNNER_UP_M, runner_up_index
from skyrender.render import Terrain, render_skylines

TILES = sorted(glob.glob("../shared/data/dem/N4*.hgt"))
SIZES = {f"ch1/{r['id']}": (int(r["width"]), int(r["height"]))
         for r in csv.DictReader(open("../shared/data/photos/ch1/index.csv"))}


def shares(terrain: Terrain, poses: np.ndarray, W: int, H: int) -> list[float]:
    """Invented share of each refined pose's (x, y, z, pan, tilt, swing, f_px, ...) rendered skyline."""
    out = []
    for p in poses:
        intr = Intrinsics(W, H, float(p[6]), W / 2.0, H / 2.0)
        sky, dist = render_skylines(terrain, p[None, :6], intr, with_distance=True)
        out.append(invented_skyline_share(terrain.dem, Pose(*p[:6]), intr, sky[0], dist[0]))
    return out


def main(paths: list[str]) -> None:
    terrains: dict = {}
    for path in paths:
        with open(path) as f:
            d = json.load(f)
        for r in d.get("rows") or d.get("photos"):
            window = tuple(round(float(v), 4) for v in r["window"])
            if window not in terrains:
                terrains.clear()
                dem = load_dem(TILES, bounds=window)
                terrains[window] = Terrain(dem) if dem.invented is not None else None
            terrain = terrains[window]
            if terrain is None:
                continue
            refined = np.array(r["refined_poses"])
            best = int(np.argmin(refined[:, 7]))
            ru = runner_up_index(refined[:, :2], refined[:, 7], best, PHOTO_RUNNER_UP_M)
            W, H = SIZES[r["photo"]]
            picks = [best] + ([ru] if ru is not None else [])
            share = shares(terrain, refined[picks], W, H)
            err = r.get("error_m", r.get("withheld_error_m"))
            print(f"{r['photo']:34s} {r['fov_mode']:7s} error {err:8.0f} m conf {r['confidence']:.3f} "
                  f"answer {refined[best, 7]:.2f} px, {share[0]:.0%} invented; runner-up "
                  + (f"{refined[ru, 7]:.2f} px, {share[1]:.0%} invented" if ru is not None else "none"), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
