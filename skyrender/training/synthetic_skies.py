"""Rendered training photographs with varied skies, for the sky network.

Views of seeded fractal terrain, of the built-in DEM and, where ``../shared/data``
is present, of an Alpine SRTM tile; each with a random sky type (clear, hazy,
overcast, sunset with the sun behind the ridges), and at random cloud banks on the
ridges, power lines, foreground occluders, haze, snow line and sensor noise. The
truth is the sky mask: above the visible sky boundary of each column (occluders
included; clouds and cables are sky). Deterministic for a seed.
"""

from __future__ import annotations

import os

import numpy as np

from ..camera import Intrinsics
from ..dem import fractal_terrain, load_dem
from ..render import Terrain, render_skylines
from ..render.photo import Look, render_photo

ALPINE_TILE = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared", "data", "dem",
                                            "N46E007.hgt"))


def _terrains(seed: int) -> list[Terrain]:
    dems = [fractal_terrain(seed=seed), fractal_terrain(seed=seed + 1), load_dem("builtin:jacksboro")]
    if os.path.exists(ALPINE_TILE):
        dems.append(load_dem(ALPINE_TILE))
    return [Terrain(d) for d in dems]


def _summits(dem, share: float = 0.1, most: int = 5000) -> np.ndarray:
    """(N, 2) world x, y of (a sample of) the highest ``share`` of the DEM's cells: what a
    photographer points the camera at."""
    z = dem.elevation
    rows, cols = np.nonzero(z >= np.nanquantile(z, 1 - share))
    step = max(1, len(rows) // most)
    return np.column_stack([dem.x_centres[cols[::step]], dem.y_centres[rows[::step]]])


def random_look(rng: np.random.Generator, pan: float, seed: int) -> Look:
    """A random appearance: sky type, clouds, cables, occluders, haze, sun, noise."""
    sky = str(rng.choice(["clear", "hazy", "overcast", "sunset"]))
    if sky == "sunset":  # the sun low, behind the ridges in view
        sun_az, sun_el = (pan + rng.uniform(-35, 35)) % 360, rng.uniform(0.5, 8.0)
    else:
        sun_az, sun_el = rng.uniform(0, 360), rng.uniform(10, 60)
    return Look(sun_azimuth=float(sun_az), sun_elevation=float(sun_el),
                haze_distance=float(rng.choice([8_000.0, 20_000.0, 40_000.0, 80_000.0])),
                snowline=None if rng.random() < 0.5 else float(rng.uniform(800, 3500)),
                noise=float(rng.uniform(0, 0.02)), occluders=float(rng.uniform(0.03, 0.12)) if rng.random() < 0.2 else 0.0,
                supersample=2, seed=seed, sky=sky, clouds=float(rng.uniform(0.3, 0.9)) if rng.random() < 0.45 else 0.0,
                power_lines=int(rng.integers(1, 4)) if rng.random() < 0.2 else 0)


def training_renders(n: int, seed: int = 0, size: tuple[int, int] = (640, 480)):
    """Yield ``n`` (name, RGB uint8 image, (H, W) float P(sky) mask) renders."""
    rng = np.random.default_rng(seed)
    terrains = _terrains(seed)
    W, H = size
    made = 0
    while made < n:
        terrain = terrains[made % len(terrains)]
        dem = terrain.dem
        xmin, xmax, ymin, ymax = dem.extent
        mx, my = 0.1 * (xmax - xmin), 0.1 * (ymax - ymin)
        x, y = rng.uniform(xmin + mx, xmax - mx), rng.uniform(ymin + my, ymax - my)
        summits = _summits(dem)
        dist = np.hypot(summits[:, 0] - x, summits[:, 1] - y)
        ahead = np.flatnonzero((dist > 1500) & (dist < 20_000))
        if len(ahead) == 0:
            continue
        tx, ty = summits[rng.choice(ahead)]
        pan = float(np.degrees(np.arctan2(tx - x, ty - y)) + rng.uniform(-20, 20)) % 360
        intr = Intrinsics.from_fov(float(rng.uniform(30, 70)), W, H)
        height = float(rng.choice([2.0, 2.0, 10.0, 50.0]))
        level = dem.camera_pose(x, y, height, pan, 0.0, 0.0)
        sky = render_skylines(terrain, level, intr)
        if np.mean(np.isfinite(sky)) < 0.9:
            continue
        # the skyline between a fifth and a half of the frame down
        want = rng.uniform(0.2, 0.5) * H
        tilt = np.degrees(np.arctan((intr.cy - np.nanmedian(sky)) / intr.f_px) - np.arctan((intr.cy - want) / intr.f_px))
        pose = dem.camera_pose(x, y, height, pan, float(np.clip(tilt, -30, 30)), float(rng.uniform(-8, 8)))
        look = random_look(rng, pan, seed * 1000 + made)
        photo = render_photo(terrain, pose, intr, look)
        boundary = np.where(np.isfinite(photo.sky_boundary), photo.sky_boundary, H)
        if np.nanstd(boundary) < 3.0 or np.mean(boundary <= 0) > 0.3:
            continue
        rows = np.arange(H)[:, None] + 0.5
        mask = np.clip(boundary[None, :] - (rows - 0.5), 0, 1)  # sky coverage of each pixel
        yield f"render{made:03d}-{look.sky}", photo.image, mask
        made += 1
