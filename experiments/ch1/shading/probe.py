"""Does the terrain's shading tell the right place from a look-alike? (a probe on stored poses, 2026-12-06, session 24)

``python experiments/ch1/shading/probe.py OUT.json [ROWS.json]`` (default rows: ``../confidence-train-rows.json``, the
73 training-side photos, fov known; run from the repository root).

The localizer matches the skyline alone, and a look-alike place 20-60 km away can fit it as well as the right one. But
the photo shows more than its skyline: the slopes below it are lit by the sun, and their pattern of light and shade
follows the terrain's normals at the right place, not at a look-alike. For each row's best 4 distinct places among its
refined poses (more than 1 km apart, the answer first: as
:func:`~skyrender.benchmarks.real_localize.stored_places` picks them), the
photo and the place's view are compared at a quarter of the photo's size:

- the place's view: every pixel's ray cast into the DEM (:func:`~skyrender.render.photo.cast_pixel_rays`), its hit's
  unit normal and distance;
- the pixels compared: terrain in both (the ray hits, and the pixel lies more than 3 px below the photo's skyline),
  the hit farther than ``NEAR_M`` (the ground at the camera's feet, skiers and fences are not in the DEM);
- the photo's lightness (CIE L) against Lambert shading max(0, n . s) for a sun ``s`` on a grid of azimuths (every 10
  deg) and elevations (10-60 deg): the best Pearson correlation over the grid (the sun fitted, the date unknown), and
  the same with the lightness and the shading ranked (Spearman: snow and rock differ in albedo more than in shade).

Lower is better in the records (the negative correlation), so :func:`~skyrender.benchmarks.real_localize.place_report`
reads them as it reads skyline scores: how often the best place by each cue is within 1 km, against the refined
skyline score's choice (the answer).
"""

from __future__ import annotations

import json
import os
import sys

import cv2
import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, place_report, refined_of, with_terrain
from skyrender.camera import Intrinsics, Pose
from skyrender.datasets.real_photos import REPO, items_on_side
from skyrender.localizer.confidence import distinct_places
from skyrender.render.photo import cast_pixel_rays

ROWS = os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")
SCALE = 4  # the views compared at a quarter of the photo's size
NEAR_M = 300.0
AZIMUTHS = np.radians(np.arange(0.0, 360.0, 10.0))
ELEVATIONS = np.radians(np.arange(10.0, 61.0, 10.0))
SUNS = np.array([[np.sin(a) * np.cos(e), np.cos(a) * np.cos(e), np.sin(e)] for a in AZIMUTHS for e in ELEVATIONS])


def lightness(image: np.ndarray, width: int, height: int) -> np.ndarray:
    """(height, width) CIE L (0-100) of an RGB uint8 photo reduced to that size."""
    small = cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
    return cv2.cvtColor(small, cv2.COLOR_RGB2Lab)[..., 0]


def best_correlation(values: np.ndarray, shading: np.ndarray) -> float:
    """The largest Pearson correlation of ``values`` (N,) with any column of ``shading`` (N, S); 0 for N < 50."""
    if len(values) < 50:
        return 0.0
    v = (values - values.mean()) / max(values.std(), 1e-9)
    s = shading - shading.mean(axis=0)
    s /= np.maximum(s.std(axis=0), 1e-9)
    return float((v @ s).max() / len(v))


def ranks(a: np.ndarray) -> np.ndarray:
    """Ranks (0..N-1) along the first axis, ties broken by order."""
    return np.argsort(np.argsort(a, axis=0, kind="stable"), axis=0, kind="stable").astype(np.float64)


def place_cues(terrain, pose: np.ndarray, photo_L: np.ndarray, sky_small: np.ndarray) -> dict:
    """The shading cues of one place (``pose``: x, y, z, pan, tilt, swing, f_px of the full photo, score) against the
    reduced photo's lightness and skyline."""
    h, w = photo_L.shape
    k = Intrinsics(w, h, pose[6] / SCALE, w / 2.0, h / 2.0)
    t, _, normals, _ = cast_pixel_rays(terrain, Pose(*pose[:6]), k)
    v = np.arange(h)[:, None] + 0.5
    below = v > np.where(np.isfinite(sky_small), sky_small, np.inf)[None, :] + 3.0
    use = np.isfinite(t) & (t > NEAR_M) & below
    n = normals[use]
    shading = np.clip(n @ SUNS.T, 0.0, None)
    values = photo_L[use].astype(np.float64)
    return {"pixels": int(use.sum()), "pearson": best_correlation(values, shading),
            "spearman": best_correlation(ranks(values), ranks(shading)) if use.sum() >= 50 else 0.0}


def main(out: str, rows_path: str = ROWS) -> None:
    rows = json.load(open(rows_path))["rows"]
    items = {it.key: it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")}
    records = []
    for row, it, terrain in with_terrain([r for r in rows if r["photo"] in items], items):
        image, sky, _ = photo_skyline(it)  # the photo and its skyline as the photo preset extracts it
        poses = refined_of(row)
        picked = poses[distinct_places(poses, 4)]
        if len(picked) < 2:
            continue
        H, W = image.shape[:2]
        w, h = W // SCALE, H // SCALE
        photo_L = lightness(image, w, h)
        sky_small = np.interp((np.arange(w) + 0.5) * SCALE - 0.5, np.arange(W), sky) / SCALE
        cues = [place_cues(terrain, p, photo_L, sky_small) for p in picked]
        truth = np.asarray(row["truth_xy"])
        records.append({"photo": it.key, "dist_m": np.hypot(*(picked[:, :2] - truth).T).tolist(),
                        "pixels": [c["pixels"] for c in cues],
                        "scores": {"skyline": picked[:, 7].tolist(),
                                   "pearson": [-c["pearson"] for c in cues],
                                   "spearman": [-c["spearman"] for c in cues]}})
        r = records[-1]
        print(it.key, " ".join(f"{d / 1000:6.1f}km {p:+.2f}/{s:+.2f}" for d, p, s in
                               zip(r["dist_m"], r["scores"]["pearson"], r["scores"]["spearman"])), flush=True)
    place_report(records, ["skyline", "pearson", "spearman"], out)


if __name__ == "__main__":
    main(*sys.argv[1:])
