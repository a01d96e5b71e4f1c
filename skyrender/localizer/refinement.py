"""Stage 4b — refinement of a verified pose against the photo's skyline.

1. Local search (coarse to fine) over (x, y) around the pose: every grid
   position is rendered in one batch with the pose's orientation, and the
   rendered skyline is aligned to the photo's by a 2-D shift and slope (what
   small pan, tilt and swing changes do to a skyline); the best aligned
   position wins and its alignment corrects the orientation. A camera 2 m above
   rough ground sees its foreground ridges move by pixels per metre, so a plain
   gradient method from a pose tens of metres off stalls; the grid does not.
2. Sub-pixel least squares (``scipy.optimize.least_squares``, soft-L1 loss)
   over (pan, tilt, swing), then (x, y, pan, tilt, swing), and the focal length
   too when it is unknown; z stays g(x, y) + height. The Jacobian comes from one
   batched render of the pose and its forward-difference neighbours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..camera import Intrinsics
from ..render import Terrain, render_skylines
from .verification import ScoreParams, column_errors, score_skylines

#: Forward-difference steps: metres for x, y; degrees for the angles; relative for f.
STEP_XY_M = 2.0
STEP_DEG = 0.01
STEP_F_REL = 1e-3
#: Bisection tolerance (px) of the renders inside the fit: well below the steps' effect.
FIT_TOL_PX = 0.01


@dataclass(frozen=True)
class Refined:
    """A refined pose (x, y, z, pan, tilt, swing), its focal length (px), score and agreement."""

    pose: np.ndarray
    f_px: float
    score: float
    agreement: float
    evaluations: int


#: Local search: grid half-widths (m), 7 x 7 positions each; alignment shifts (px).
SEARCH_RADII_M = (160.0, 45.0, 12.0, 3.0)
SEARCH_POINTS = 7
SHIFTS_PX = np.arange(-12.0, 12.01, 0.5)


def align_skylines(rendered: np.ndarray, image: np.ndarray, columns: np.ndarray, cx: float, weights: np.ndarray,
                   shifts: np.ndarray = SHIFTS_PX, params: ScoreParams = ScoreParams()):
    """Best 2-D alignment of rendered skylines (P, n) to the photo's (n,), both sampled
    at image columns ``columns`` (u = column + 0.5): the rendered curve moved right by
    ``a`` px and by ``b + c (u - cx)`` px down, a from ``shifts``, b and c by weighted
    least squares. Returns (score (P,), a (P,), b (P,), c (P,)).
    """
    u = columns + 0.5
    P = len(rendered)
    step = u[1] - u[0] if len(u) > 1 else 1.0
    best = (np.full(P, np.inf), np.zeros(P), np.zeros(P), np.zeros(P))
    x = u - cx
    for a in shifts:
        # rendered value at u - a, linear between samples (NaN stays NaN)
        pos = (u - a - u[0]) / step
        i0 = np.clip(np.floor(pos).astype(np.int64), 0, len(u) - 1)
        i1 = np.clip(i0 + 1, 0, len(u) - 1)
        t = np.clip(pos - i0, 0.0, 1.0)
        moved = rendered[:, i0] * (1 - t) + rendered[:, i1] * t
        moved[:, (pos < 0) | (pos > len(u) - 1)] = np.nan
        d = image[None, :] - moved
        w = np.where(np.isfinite(d), weights[None, :], 0.0)
        d0 = np.where(np.isfinite(d), d, 0.0)
        # robust line fit: least squares, then again without the columns beyond 3 px
        for _ in range(2):
            sw, sx, sxx = w.sum(1), (w * x).sum(1), (w * x * x).sum(1)
            sy, sxy = (w * d0).sum(1), (w * x * d0).sum(1)
            det = np.maximum(sw * sxx - sx * sx, 1e-9)
            c = (sw * sxy - sx * sy) / det
            b = (sy - c * sx) / np.maximum(sw, 1e-9)
            w = np.where(np.abs(d0 - b[:, None] - c[:, None] * x) <= 3.0, w, 0.0) * np.isfinite(d)
        score, _ = score_skylines(moved + b[:, None] + c[:, None] * x, image, weights, params)
        better = score < best[0]
        best = tuple(np.where(better, new, old) for new, old in zip((score, np.full(P, a), b, c), best))
    return best


def local_search(terrain: Terrain, pose: np.ndarray, intrinsics: Intrinsics, height: float,
                 image_skyline: np.ndarray, weights: np.ndarray, f_px: float, stride: int = 2,
                 params: ScoreParams = ScoreParams()) -> tuple[np.ndarray, int]:
    """Coarse-to-fine grid search over (x, y) with the orientation re-aligned per
    position (:func:`align_skylines`); returns the improved pose and the renders used."""
    dem = terrain.dem
    cols = np.arange(stride // 2, intrinsics.width, stride)
    k = np.array([f_px, intrinsics.cx, intrinsics.cy])
    pose = np.asarray(pose, np.float64).copy()
    renders = 0
    g = np.linspace(-1.0, 1.0, SEARCH_POINTS)
    for radius in SEARCH_RADII_M:
        gx, gy = np.meshgrid(g * radius, g * radius)
        xy = pose[:2] + np.column_stack([gx.ravel(), gy.ravel()])
        z = dem.ground(xy[:, 0], xy[:, 1]) + height
        inside = np.isfinite(z)
        poses = np.column_stack([xy, z, np.tile(pose[3:], (len(xy), 1))])[inside]
        rendered = render_skylines(terrain, poses, intrinsics, per_pose_intrinsics=k, tol=0.1)[:, cols]
        renders += len(poses)
        score, a, b, c = align_skylines(rendered, image_skyline[cols], cols, intrinsics.cx, weights[cols],
                                        params=params)
        j = int(np.argmin(score))
        pose = poses[j].copy()
        # a shift right by a px is a pan left by a / f; down by b is a tilt up... see CONTRACT.md axes
        pose[3] = (pose[3] - np.degrees(np.arctan(a[j] / f_px))) % 360.0
        pose[4] = pose[4] + np.degrees(np.arctan(b[j] / f_px))
        pose[5] = pose[5] - np.degrees(np.arctan(c[j]))
    return pose, renders


def refine_pose(terrain: Terrain, pose: np.ndarray, intrinsics: Intrinsics, height: float,
                image_skyline: np.ndarray, weights: np.ndarray, *, fit_focal: bool = False,
                f_px: float | None = None, max_nfev: int = 30, search: bool = True,
                params: ScoreParams = ScoreParams()) -> Refined:
    """Refine one pose (6,) against the photo's skyline (W,): local search, then least squares."""
    f0 = intrinsics.f_px if f_px is None else float(f_px)
    renders = 0
    pose = np.asarray(pose, np.float64)
    if search:
        pose, renders = local_search(terrain, pose, intrinsics, height, image_skyline, weights, f0, params=params)
    q = np.r_[pose[0], pose[1], pose[3], pose[4], pose[5], f0]
    for free in ([2, 3, 4], [0, 1, 2, 3, 4] + ([5] if fit_focal else [])):
        q, n = _least_squares(terrain, q, free, intrinsics, height, image_skyline, weights, max_nfev, params)
        renders += n
    final, k = _pose_of(terrain.dem, q[None], height, intrinsics)
    final = final[0]
    final[3] %= 360.0
    if not np.isfinite(final[2]):
        return Refined(pose, f0, np.inf, 0.0, renders)
    rendered = render_skylines(terrain, final, intrinsics, per_pose_intrinsics=k)
    score, agreement = score_skylines(rendered[None], image_skyline, weights, params)
    return Refined(final, float(q[5]), float(score[0]), float(agreement[0]), renders)


def _pose_of(dem, qs: np.ndarray, height: float, intrinsics: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Poses (P, 6) and per-pose intrinsics (P, 3) of parameter rows (x, y, pan, tilt, swing, f)."""
    z = dem.ground(qs[:, 0], qs[:, 1]) + height
    poses = np.column_stack([qs[:, 0], qs[:, 1], z, qs[:, 2], qs[:, 3], qs[:, 4]])
    return poses, np.column_stack([qs[:, 5], np.full(len(qs), intrinsics.cx), np.full(len(qs), intrinsics.cy)])


def _least_squares(terrain: Terrain, q0: np.ndarray, free: list[int], intrinsics: Intrinsics, height: float,
                   image_skyline: np.ndarray, weights: np.ndarray, max_nfev: int,
                   params: ScoreParams) -> tuple[np.ndarray, int]:
    """least_squares over the ``free`` entries of q = (x, y, pan, tilt, swing, f)."""
    sqrt_w = np.sqrt(np.asarray(weights, np.float64))
    all_steps = np.r_[STEP_XY_M, STEP_XY_M, STEP_DEG, STEP_DEG, STEP_DEG, STEP_F_REL * q0[5]]
    steps = all_steps[free]
    counter = [0]

    def full(p: np.ndarray) -> np.ndarray:
        qs = np.tile(q0, (len(p), 1))
        qs[:, free] = p
        return qs

    def residuals_of(p: np.ndarray) -> np.ndarray:
        poses, k = _pose_of(terrain.dem, full(p), height, intrinsics)
        inside = np.isfinite(poses[:, 2])
        out = np.full((len(p), intrinsics.width), -params.cap_px)
        if inside.any():
            counter[0] += int(inside.sum())
            rendered = render_skylines(terrain, poses[inside], intrinsics, tol=FIT_TOL_PX,
                                       per_pose_intrinsics=k[inside])
            e = np.clip(column_errors(rendered, image_skyline, params.cap_px), -params.cap_px, params.cap_px)
            out[inside] = np.where(e < 0, e, params.occluder_weight * e)
        return out * sqrt_w

    cache: dict = {}

    def fun(p):
        key = p.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = residuals_of(p[None])[0]
        return cache[key]

    def jac(p):
        r0 = fun(p)
        rs = residuals_of(p[None] + np.diag(steps))
        return ((rs - r0) / steps[:, None]).T

    result = least_squares(fun, q0[free], jac=jac, loss="soft_l1", f_scale=1.0, x_scale=steps * 5,
                           max_nfev=max_nfev, xtol=1e-6, ftol=1e-6)
    return full(result.x[None])[0], counter[0]
