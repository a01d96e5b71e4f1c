"""gmm's first sky seed (``skyline._top_components``): the rule before (the smooth top component
covering most of the top row is the sky) and after (unless it also reaches the bottom fifth of the
frame). Does the choice change on any real photo or benchmark render?

``python experiments/photos/slope-seed/check.py [RENDERED_PNG ...]`` writes ``check.txt`` beside it:
every real photo of every side, bench-localize's 10 views, and any rendered PNGs given (the session
that made the rule passed bench-scale's 8 synthetic and 8 tile views).
"""

from __future__ import annotations

import os
import sys

import cv2
import numpy as np
from scipy import ndimage

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", ".."))

from skyrender.benchmarks.views import bench_localize_views  # noqa: E402
from skyrender.datasets.real_photos import items_on_side  # noqa: E402
from skyrender.dem.synthetic import fractal_terrain  # noqa: E402
from skyrender.evaluate import git_commit  # noqa: E402
from skyrender.features import load_photo  # noqa: E402
from skyrender.features.sky import pixel_features  # noqa: E402
from skyrender.features.skyline import _top_components  # noqa: E402
from skyrender.model import build_model  # noqa: E402
from skyrender.render import Terrain  # noqa: E402


def rule_before(features, labels, max_lab_distance=15.0):
    top, counts = np.unique(labels[0][labels[0] > 0], return_counts=True)
    if len(top) <= 1:
        return top, top[:0]
    means = np.stack([ndimage.mean(features[..., c], labels, top) for c in range(3)], axis=1)
    sky_like = np.linalg.norm(means - means[np.argmax(counts)], axis=1) <= max_lab_distance
    return top[sky_like], top[~sky_like]


def same_choice(image: np.ndarray) -> bool:
    """The components as ``initial_seeds`` labels them; both rules' (sky, others) equal?"""
    features = pixel_features(image)
    grad = ndimage.uniform_filter(features[..., 4], 5)
    labels, _ = ndimage.label(grad < max(0.6, float(np.percentile(grad, 35))))
    before, after = rule_before(features, labels), _top_components(features, labels)
    return all(np.array_equal(a, b) for a, b in zip(before, after))


def main(rendered: list[str]) -> None:
    images = [(it.key, lambda it=it: load_photo(it.image_path))
              for side in ("train", "dev", "validation", "heldout") for it in items_on_side(side)]
    images += [(path, lambda path=path: cv2.cvtColor(cv2.imread(path), cv2.COLOR_BGR2RGB)) for path in rendered]
    dem = fractal_terrain()
    terrain = Terrain(dem)
    _, _, photos = bench_localize_views(terrain, build_model(dem, terrain=terrain), 10, 1)
    images += [(f"bench-localize view {i}", lambda p=p: p) for i, p in enumerate(photos)]
    changed = [name for name, load in images if not same_choice(load())]
    text = f"commit {git_commit()}: {len(images)} images, the sky seed's choice changed on {len(changed)}: {changed}"
    with open(os.path.join(HERE, "check.txt"), "w") as f:
        f.write(text + "\n")
    print(text)


if __name__ == "__main__":
    main(sys.argv[1:])
