"""Cables painted over before extraction (skyrender.features.cables): where the mask fires, and what it changes.

``python experiments/photos/cables/probe.py`` (writes ``probe.json`` and ``probe.txt`` beside it):

1. every real photo of every side (train, dev, validation, held out): the cable mask's pixel count
   (photos wider than 1600 px at 1024, as the extractor sees them); where it is empty the extractor
   gets the very same array, so that photo's skyline is byte for byte the previous one;
2. where it is not: the photo's hybrid / gmm / net error with the cables painted over and without;
3. renders of the built-in scene with two cables (4 seeds x 3 skies), each extractor with and without;
4. renders without cables (every sky, clouds, occluders, 6 seeds, both views): the mask must stay empty.
"""

from __future__ import annotations

import json
import os
import sys

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", ".."))

from skyrender.benchmarks.skyline_photos import column_errors  # noqa: E402
from skyrender.datasets.real_photos import items_on_side  # noqa: E402
from skyrender.evaluate import git_commit  # noqa: E402
from skyrender.features import SkylineParams, extract_skyline, load_photo  # noqa: E402
from skyrender.features.cables import cable_mask  # noqa: E402
from skyrender.render import Terrain  # noqa: E402
from skyrender.render.photo import SKY_TYPES, Look, render_photo  # noqa: E402
from skyrender.scenes import load_scene  # noqa: E402

METHODS = ("hybrid", "gmm", "net")


def errors(image, truth, method, cables):
    params = SkylineParams(method=method) if cables else SkylineParams(method=method, cables=None)
    e = column_errors(extract_skyline(image, params).skyline, truth)
    return {"median": round(float(np.median(e)), 2), "within5": round(float(np.mean(e <= 5)), 4)}


def main() -> None:
    out, lines = {"commit": git_commit(), "photos": {}, "renders_with_cables": [], "renders_without": 0}, []
    for side in ("train", "dev", "validation", "heldout"):
        items, found = items_on_side(side), 0
        for it in items:
            image = load_photo(it.image_path)
            if image.shape[1] > 1600:
                image = cv2.resize(image, (1024, int(round(image.shape[0] * 1024 / image.shape[1]))),
                                   interpolation=cv2.INTER_AREA)
            n = int(cable_mask(image).sum())
            if n:
                found += 1
                truth = it.truth_skyline()
                row = {"side": side, "mask_px": n}
                for m in METHODS:
                    row[m] = {"without": errors(image, truth, m, False), "painted_over": errors(image, truth, m, True)}
                out["photos"][it.key] = row
                lines.append(f"{side} {it.key}: mask {n} px; " + "; ".join(
                    f"{m} {row[m]['without']['within5'] * 100:.1f} -> {row[m]['painted_over']['within5'] * 100:.1f} %"
                    for m in METHODS))
        lines.append(f"{side}: a cable found on {found} of {len(items)} photos")
    scene = load_scene(os.path.join(HERE, "..", "..", "..", "scenes", "jacksboro.toml"))
    terrain = Terrain(scene.dem)
    pose, K = scene.views[0].pose, scene.views[0].intrinsics
    for seed in (13, 14, 15, 16):
        for sky in ("overcast", "clear", "hazy"):
            photo = render_photo(terrain, pose, K, Look(sky=sky, power_lines=2, seed=seed))
            row = {"seed": seed, "sky": sky, "mask_px": int(cable_mask(photo.image).sum())}
            for m in ("hybrid", "gmm"):
                row[m] = {"without": errors(photo.image, photo.sky_boundary, m, False),
                          "painted_over": errors(photo.image, photo.sky_boundary, m, True)}
            out["renders_with_cables"].append(row)
            lines.append(f"render seed {seed} {sky:8s}: " + "; ".join(
                f"{m} median {row[m]['without']['median']:.2f} -> {row[m]['painted_over']['median']:.2f} px, within 5 px "
                f"{row[m]['without']['within5'] * 100:.0f} -> {row[m]['painted_over']['within5'] * 100:.0f} %"
                for m in ("hybrid", "gmm")))
    false_positives = []
    for view in scene.views:
        for seed in range(6):
            for sky in SKY_TYPES:
                for extra in ({}, {"clouds": 0.7}, {"occluders": 0.2}, {"noise": 0.02}):
                    photo = render_photo(terrain, view.pose, view.intrinsics, Look(sky=sky, seed=seed, **extra))
                    out["renders_without"] += 1
                    if cable_mask(photo.image).any():
                        false_positives.append([view.name, seed, sky, extra])
    out["false_positives"] = false_positives
    lines.append(f"renders without cables: a cable found on {len(false_positives)} of {out['renders_without']}")
    with open(os.path.join(HERE, "probe.json"), "w") as f:
        json.dump(out, f, indent=1)
    with open(os.path.join(HERE, "probe.txt"), "w") as f:
        f.write(f"commit {out['commit']}\n" + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
