"""A hash of gmm's first-round seeds (``skyline.initial_seeds``: the sky and terrain masks) for every
real photo, bench-localize's 10 views and any rendered PNGs given, written to OUT.json: run it once
with the code before a change to the seeds (``PYTHONPATH=<worktree at that commit>``) and once with
the change, and compare the two files; an image whose hash is equal gets the same gmm skyline.

``python experiments/photos/slope-seed/seed_hashes.py OUT.json [RENDERED_PNG ...]``
"""

from __future__ import annotations

import hashlib
import json
import sys

import cv2
import numpy as np

from skyrender.benchmarks.views import bench_localize_views
from skyrender.datasets.real_photos import items_on_side
from skyrender.dem.synthetic import fractal_terrain
from skyrender.features import load_photo
from skyrender.features.sky import pixel_features
from skyrender.features.skyline import initial_seeds
from skyrender.model import build_model
from skyrender.render import Terrain


def seed_hash(image: np.ndarray) -> str:
    sky, terrain = initial_seeds(pixel_features(image))
    return hashlib.sha1(np.packbits(sky).tobytes() + np.packbits(terrain).tobytes()).hexdigest()


def main(out: str, rendered: list[str]) -> None:
    hashes = {it.key: seed_hash(load_photo(it.image_path))
              for side in ("train", "dev", "validation", "heldout") for it in items_on_side(side)}
    hashes.update({path: seed_hash(cv2.cvtColor(cv2.imread(path), cv2.COLOR_BGR2RGB)) for path in rendered})
    dem = fractal_terrain()
    terrain = Terrain(dem)
    _, _, photos = bench_localize_views(terrain, build_model(dem, terrain=terrain), 10, 1)
    hashes.update({f"bench-localize view {i}": seed_hash(p) for i, p in enumerate(photos)})
    with open(out, "w") as f:
        json.dump(hashes, f, indent=1)
    print(f"{len(hashes)} images -> {out}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
