"""Polish the best refined places again: does the right place gain more than the look-alikes? (a probe, 2026-12-05)

``python experiments/ch1/polish/probe.py OUT.json KEY [KEY ...]``

Where the extraction is good and a look-alike still wins (``../near-skylines/README.md``), the right place's refined
pose can be under-converged: on dev ``IMG_1854`` the shipped rows refine it to 890 m from the truth at 2.01 px, while a
refinement started at the truth reached 1.50 px (``../truth-refine-dev-swing8.json``), better than the look-alike's
1.77. For each photo (training side, fov known), the best K = 4 distinct places (more than 1 km apart) among the stored
refined poses of ``../confidence-train-rows.json`` are polished: moved to the best of a 9 x 9 grid +-600 m
(``local_rescore``, every 8th column), then refined again (``refine_pose``, the photo preset's parameters). Reported:
each place's distance to the truth and score before and after.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, refined_of, with_terrain
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import REPO, items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer.confidence import distinct_places
from skyrender.localizer.refinement import local_rescore, refine_pose

ROWS = os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")


def main(out: str, keys: list[str]) -> None:
    rows = {r["photo"]: r for r in json.load(open(ROWS))["rows"]}
    items = {it.key: it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")}
    params = LocalizeParams.for_photos()
    result = []
    for row, it, terrain in with_terrain([rows[key] for key in keys], items):
        key = it.key
        image, sky, weights = photo_skyline(it, params)
        H, W = image.shape[:2]
        K = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
        truth = np.asarray(row["truth_xy"])
        poses = refined_of(row)
        places = []
        for i in distinct_places(poses, 4):
            moved, _ = local_rescore(terrain, poses[i:i + 1, :6], K, 2.0, sky, weights, 600.0, 9, 8, params.score)
            r = refine_pose(terrain, moved[0], K, 2.0, sky, weights, params=params.score, refine=params.refine,
                            give_up_px=params.give_up_sweep_px)
            places.append({"before_m": float(np.hypot(*(poses[i, :2] - truth))), "before_px": float(poses[i, 7]),
                           "after_m": float(np.hypot(*(r.pose[:2] - truth))), "after_px": float(r.score)})
        result.append({"photo": key, "error_m": row["error_m"], "places": places})
        print(key, " | ".join(f"{p['before_m'] / 1000:.1f} km {p['before_px']:.2f} -> {p['after_m'] / 1000:.1f} km "
                              f"{p['after_px']:.2f}" for p in places), flush=True)
    json.dump(result, open(out, "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
