"""Synthetic test views with known poses, for the localizer's tests and benchmark.

A view is a camera ``height`` metres above a random position, turned towards a
pivot (major peak) that is a skyline feature 2–15 km away (a photograph *of a
mountain*), tilted so the skyline sits a little above the image centre, with a
random swing. The method needs three of the photo's largest skyline peaks to be
model feature points (Naval 2000, section 2.1), so a view is kept only when at
least ``min_matches`` of its top ``n_peaks`` skyline peaks lie within
``match_px`` of a feature point's projection; :func:`sample_views` reports how
many candidates it drew to find them (the share of random mountain views for
which the method applies at all).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Intrinsics, Pose, project
from ..features import skyline_peaks
from ..model import Model
from ..model.covisibility import skyline_features
from ..render import Terrain, render_skylines


@dataclass(frozen=True)
class ViewSample:
    poses: list[Pose]
    targets: list[int]  # feature-table row of the pivot each view is turned towards
    drawn: int  # candidate views drawn to find them


def peaks_on_features(skyline: np.ndarray, pose: Pose, intrinsics: Intrinsics, features_xyz: np.ndarray,
                      n_peaks: int, match_px: float) -> int:
    """How many of the skyline's top ``n_peaks`` peaks lie within ``match_px`` of a projected feature."""
    peaks = skyline_peaks(skyline, n=n_peaks)
    if not peaks:
        return 0
    uv, front = project(features_xyz, pose, intrinsics)
    apex = np.array([[p.u, p.v] for p in peaks])
    d = np.hypot(uv[None, :, 0] - apex[:, None, 0], uv[None, :, 1] - apex[:, None, 1])
    d[:, ~front] = np.inf
    nearest = np.argmin(d, axis=1)
    close = d[np.arange(len(apex)), nearest] <= match_px
    return len(set(nearest[close].tolist()))


def sample_views(terrain: Terrain, model: Model, intrinsics: Intrinsics, n: int, *, height: float = 2.0,
                 swing_deg: float = 0.0, seed: int = 0, n_peaks: int = 8, min_matches: int = 3,
                 match_px: float = 4.0, max_draws: int = 5000) -> ViewSample:
    """``n`` views (deterministic for a seed) that satisfy the method's precondition."""
    dem = terrain.dem
    rng = np.random.default_rng(seed)
    xmin, xmax, ymin, ymax = dem.extent
    margin = 0.05 * min(xmax - xmin, ymax - ymin)
    feats = model.features
    poses: list[Pose] = []
    targets: list[int] = []
    drawn = 0
    while len(poses) < n and drawn < max_draws:
        drawn += 1
        x, y = rng.uniform(xmin + margin, xmax - margin), rng.uniform(ymin + margin, ymax - margin)
        cam = np.array([[x, y, float(dem.ground(x, y)) + height]])
        on_sky = np.flatnonzero(skyline_features(terrain, cam, feats.xyz, model.params.covisibility)[0])
        dist = np.hypot(feats.x[on_sky] - x, feats.y[on_sky] - y)
        pivots = on_sky[feats.major[on_sky] & (dist > 2000) & (dist < 15000)]
        if len(pivots) == 0:
            continue
        t = rng.choice(pivots)
        pan = np.degrees(np.arctan2(feats.x[t] - x, feats.y[t] - y)) + rng.uniform(-15.0, 15.0)
        swing = rng.uniform(-swing_deg, swing_deg) if swing_deg else 0.0
        level = dem.camera_pose(x, y, height, pan, 0.0, swing)
        sky = render_skylines(terrain, level, intrinsics)
        if not np.isfinite(sky).any():
            continue
        # the skyline a tenth of the height above the centre
        tilt = np.degrees(np.arctan((intrinsics.cy - np.nanmedian(sky)) / intrinsics.f_px)) - np.degrees(
            np.arctan(0.1 * intrinsics.height / intrinsics.f_px))
        pose = dem.camera_pose(x, y, height, pan, float(tilt), swing)
        sky = render_skylines(terrain, pose, intrinsics)
        if peaks_on_features(sky, pose, intrinsics, feats.xyz, n_peaks, match_px) >= min_matches:
            poses.append(pose)
            targets.append(int(t))
    return ViewSample(poses, targets, drawn)


#: ``make bench-localize``'s camera: 60 deg wide, 640 x 480 px.
BENCH_FOV_DEG, BENCH_SIZE = 60.0, (640, 480)


def bench_localize_views(terrain: Terrain, model: Model, n: int, seed: int):
    """``make bench-localize``'s views on ``terrain`` and its ``model``: ``n`` cameras of
    :data:`BENCH_FOV_DEG` and :data:`BENCH_SIZE` (:func:`sample_views`), and view i's rendered
    photo (``Look(seed=i)``). Returns (intrinsics, the ViewSample, the photos (H, W, 3) uint8)."""
    from ..render.photo import Look, render_photo

    intrinsics = Intrinsics.from_fov(BENCH_FOV_DEG, *BENCH_SIZE)
    sample = sample_views(terrain, model, intrinsics, n, seed=seed)
    photos = [render_photo(terrain, pose, intrinsics, Look(seed=i)).image for i, pose in enumerate(sample.poses)]
    return intrinsics, sample, photos
