"""Stage 3c — pruning constraints (Naval 2000, sections 2.5–2.6), batched.

*Skyline is the limit*: no terrain point may appear above the photo's skyline,
so a pose under which any model feature point projects above the skyline (by
more than a tolerance) is wrong. Foreground occluders only raise the photo's
skyline, so they never make this reject a right pose.

*Inter-feature-point visibility*: two image peaks joined by a segment that runs
through sky in the photo see each other, so the 3-D segment between their
feature points must be unobstructed.
"""

from __future__ import annotations

import numpy as np

from ..camera import Intrinsics, project
from ..render import Terrain
from ..render.visibility import line_of_sight

#: Pose x point projections per chunk (bounds memory).
CHUNK_PROJECTIONS = 4_000_000


def _against_skyline(poses: np.ndarray, points: np.ndarray, skyline: np.ndarray, intrinsics: Intrinsics,
                     curvature: bool):
    """Project ``points`` (F, 3) under ``poses`` (N, 6) in chunks; yields (slice of poses,
    v (n, F), inside (n, F): in front and within the image's columns, the photo skyline's
    v at each point's column (n, F), H where the column sees only sky)."""
    W, H = intrinsics.width, intrinsics.height
    sky = np.where(np.isfinite(skyline), skyline, H)
    chunk = max(1, CHUNK_PROJECTIONS // max(len(points), 1))
    for s in range(0, len(poses), chunk):
        sl = slice(s, s + chunk)
        uv, front = project(points, poses[sl], intrinsics, curvature)
        u, v = uv[..., 0], uv[..., 1]
        inside = front & (u >= 0) & (u < W)
        col = np.clip(np.where(inside, u, 0), 0, W - 1).astype(np.int64)
        yield sl, v, inside, sky[col]


def skyline_limit(poses: np.ndarray, points: np.ndarray, skyline: np.ndarray, intrinsics: Intrinsics,
                  tol_px: float = 5.0, position_slack_m: float = 150.0, curvature: bool = True,
                  first_block: int = 32) -> np.ndarray:
    """(N,) bool: True where no point projects above the image skyline by more than a tolerance.

    poses : (N, 6); points : (F, 3) world points (m); skyline : (W,) v per column
    (NaN: the column sees only sky, so any terrain point in its visible part is a violation).
    The tolerance is ``tol_px`` plus what ``position_slack_m`` of camera position error
    moves a point at its distance d: f * slack / d px. A hypothesis' pose is only as
    good as its three matched summits, and a near point moves a lot.

    The points are tested in blocks, highest first (``first_block`` of them, then four
    times as many each time), and a rejected pose is not projected again: the answer is
    that of testing every point, but most wrong poses show one of the highest summits
    above the skyline and are dropped after the first block (whole tile: 3-5x faster).
    """
    ok = np.ones(len(poses), dtype=bool)
    order = np.argsort(-points[:, 2], kind="stable")
    live, start, block = np.arange(len(poses)), 0, max(1, first_block)
    while start < len(points) and len(live):
        some = points[order[start:start + block]]
        for sl, v, inside, sky_v in _against_skyline(poses[live], some, skyline, intrinsics, curvature):
            batch = poses[live[sl]]
            distance = np.hypot(some[None, :, 0] - batch[:, None, 0], some[None, :, 1] - batch[:, None, 1])
            tol = tol_px + intrinsics.f_px * position_slack_m / np.maximum(distance, 1.0)
            ok[live[sl]] = ~(inside & (v < sky_v - tol)).any(axis=1)
        live = live[ok[live]]
        start, block = start + block, 4 * block
    return ok


def prior_in_view(poses: np.ndarray, points: np.ndarray, skyline: np.ndarray, intrinsics: Intrinsics,
                  tol_px: float = 5.0, curvature: bool = True) -> np.ndarray:
    """(N,) bool: the pose shows at least one of ``points`` (F', 3) — the peaks a prior
    says are in view — inside the image and not above the photo's skyline."""
    ok = np.zeros(len(poses), dtype=bool)
    if len(points) == 0:
        return ok
    for sl, v, inside, sky_v in _against_skyline(poses, points, skyline, intrinsics, curvature):
        ok[sl] = (inside & (v < intrinsics.height) & (v >= sky_v - tol_px)).any(axis=1)
    return ok


def segments_in_sky(peak_uv: np.ndarray, skyline: np.ndarray, tol_px: float = 1.0) -> np.ndarray:
    """(n, n) bool: does the straight image segment between peaks i and j run through
    sky (at or above the skyline, within ``tol_px``) in every column it crosses?"""
    n = len(peak_uv)
    out = np.zeros((n, n), dtype=bool)
    sky = np.where(np.isfinite(skyline), skyline, np.inf)
    for i in range(n):
        for j in range(i + 1, n):
            (u0, v0), (u1, v1) = sorted((tuple(peak_uv[i]), tuple(peak_uv[j])))
            cols = np.arange(int(np.ceil(u0 - 0.5)), int(np.floor(u1 - 0.5)) + 1)
            cols = cols[(cols >= 0) & (cols < len(sky))]
            if len(cols) == 0:
                continue
            v = v0 + (v1 - v0) * (cols + 0.5 - u0) / max(u1 - u0, 1e-9)
            out[i, j] = out[j, i] = bool(np.all(v <= sky[cols] + tol_px))
    return out


def interfeature_visibility(terrain: Terrain, image_triples: np.ndarray, feature_triples: np.ndarray,
                            features_xyz: np.ndarray, in_sky: np.ndarray) -> np.ndarray:
    """(N,) bool: for each hypothesis, every pair of its image peaks joined through sky
    has an unobstructed 3-D segment between the matched feature points.

    A segment's visibility does not depend on the pose, so each distinct feature
    pair is tested once.
    """
    N = len(image_triples)
    ok = np.ones(N, dtype=bool)
    pairs = ((0, 1), (1, 2), (0, 2))
    need = np.stack([in_sky[image_triples[:, a], image_triples[:, b]] for a, b in pairs], axis=1)  # (N, 3)
    if not need.any():
        return ok
    fa = np.stack([feature_triples[:, a] for a, _ in pairs], axis=1)[need]
    fb = np.stack([feature_triples[:, b] for _, b in pairs], axis=1)[need]
    lo, hi = np.minimum(fa, fb), np.maximum(fa, fb)
    F = len(features_xyz)
    keys, inverse = np.unique(lo * F + hi, return_inverse=True)
    # summits 10 m up: both ends graze the skyline, and a segment along a ridge should pass
    clear = line_of_sight(terrain, features_xyz[keys // F], features_xyz[keys % F], lift_m=10.0)
    blocked = np.zeros(need.shape, dtype=bool)
    blocked[need] = ~clear[inverse]
    return ~blocked.any(axis=1)


def in_image_geometry(poses: np.ndarray, points: np.ndarray, intrinsics: Intrinsics, curvature: bool,
                      margin_px: float = 5.0) -> np.ndarray:
    """(P,) bool: the pose (P, 6) is finite (inside the DEM) and its three matched points
    (P, 3, 3) lie in front of the camera and within ``margin_px`` of the image."""
    ok = np.isfinite(poses).all(axis=1)
    if not ok.any():
        return ok
    out = np.zeros(len(poses), dtype=bool)
    sub = np.flatnonzero(ok)
    uv, _ = project(points[sub], poses[sub], intrinsics, curvature)
    u, v = uv[..., 0], uv[..., 1]
    inside = (u > -margin_px) & (u < intrinsics.width + margin_px) & (v > -margin_px) & (v < intrinsics.height + margin_px)
    out[sub] = np.all(inside & np.isfinite(u), axis=1)
    return out
