"""Stage 4a — verification: render each surviving pose's skyline and score it
against the photo's skyline (Naval 2000, section 2.6, with a robust score).

Per column, e = rendered v - photo v (px). Terrain where the photo shows sky
(e < 0) is a plain error. Photo skyline above the terrain (e > 0) may be a
foreground occluder (a tree, a post), so it costs only ``occluder_weight`` of
that. Errors are capped (one bad column cannot dominate) and weighted by the
photo's per-column confidence. The score is the weighted mean cost (px); the
agreement is the weighted share of columns within ``agree_px``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Intrinsics
from ..render import Terrain, render_skylines


#: Horizontal shifts (px) tried when aligning a rendered skyline to the photo's.
SHIFTS_PX = np.arange(-30.0, 30.01, 1.0)


@dataclass(frozen=True)
class ScoreParams:
    cap_px: float = 20.0
    occluder_weight: float = 0.25
    agree_px: float = 2.0


def column_errors(rendered: np.ndarray, image: np.ndarray, cap_px: float) -> np.ndarray:
    """(..., W) rendered - image (px); a column where exactly one of them is NaN
    (sky only) counts as -cap (terrain missing or extra is never an occluder), both NaN as 0."""
    e = rendered - image
    one_nan = np.isnan(rendered) ^ np.isnan(image)
    e = np.where(one_nan, -cap_px, e)
    return np.where(np.isnan(e), 0.0, e)


def score_skylines(rendered: np.ndarray, image: np.ndarray, weights: np.ndarray,
                   params: ScoreParams = ScoreParams()) -> tuple[np.ndarray, np.ndarray]:
    """Robust score (px, lower is better) and agreement share of rendered skylines
    (P, W) against the photo's (W,), with per-column weights (W,) in [0, 1]."""
    e = column_errors(rendered, image, params.cap_px)
    cost = np.where(e < 0, np.minimum(-e, params.cap_px), params.occluder_weight * np.minimum(e, params.cap_px))
    total = max(float(np.sum(weights)), 1e-9)
    score = (cost * weights).sum(axis=-1) / total
    agreement = ((np.abs(e) <= params.agree_px) * weights).sum(axis=-1) / total
    return score, agreement


def align_skylines(rendered: np.ndarray, image: np.ndarray, columns: np.ndarray, cx: float, weights: np.ndarray,
                   shifts: np.ndarray = SHIFTS_PX, params: ScoreParams = ScoreParams()):
    """Best 2-D alignment of rendered skylines (P, n) to the photo's (n,), both sampled
    at image columns ``columns`` (u = column + 0.5): the rendered curve moved right by
    ``a`` px and by ``b + c (u - cx)`` px down, a from ``shifts``, b and c by weighted
    least squares. Returns (score, agreement, a, b, c), each (P,).
    """
    u = columns + 0.5
    P = len(rendered)
    step = u[1] - u[0] if len(u) > 1 else 1.0
    best = (np.full(P, np.inf), np.zeros(P), np.zeros(P), np.zeros(P), np.zeros(P))
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
        score, agreement = score_skylines(moved + b[:, None] + c[:, None] * x, image, weights, params)
        better = score < best[0]
        best = tuple(np.where(better, new, old) for new, old in zip((score, agreement, np.full(P, a), b, c), best))
    return best


def strided_intrinsics(intrinsics: Intrinsics, stride: int) -> tuple[Intrinsics, np.ndarray]:
    """Intrinsics of a ``stride`` times smaller image whose column k samples the full
    image's column ``stride*k + stride//2`` exactly; returns them and those columns.
    Its v coordinates scale back by ``v_full = cy + stride * (v - cy_small)``."""
    W, H = intrinsics.width, intrinsics.height
    cols = np.arange(stride // 2, W, stride)
    f = intrinsics.f_px / stride
    # column k's centre k + 0.5 must look along full column centre cols[0] + 0.5 + stride * k
    cx = 0.5 - (cols[0] + 0.5 - intrinsics.cx) / stride
    small = Intrinsics(len(cols), max(2, int(np.ceil(H / stride))), f, cx, intrinsics.cy / stride)
    return small, cols


def strided_skylines(terrain: Terrain, poses: np.ndarray, intrinsics: Intrinsics, stride: int,
                     tol_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Skylines (P, n) of poses (P, 6) on every ``stride``-th column
    (:func:`strided_intrinsics`), in full-image v (px) to within ``tol_px`` full-image
    px, and those columns (n,): a render ``stride`` times cheaper."""
    small, cols = strided_intrinsics(intrinsics, stride)
    rendered = render_skylines(terrain, poses, small, tol=tol_px / stride)
    return intrinsics.cy + stride * (rendered - small.cy), cols


def verify_poses(terrain: Terrain, poses: np.ndarray, intrinsics: Intrinsics, image_skyline: np.ndarray,
                 weights: np.ndarray, stride: int = 4,
                 params: ScoreParams = ScoreParams()) -> tuple[np.ndarray, np.ndarray]:
    """Score many poses (P, 6) on every ``stride``-th column; returns (score, agreement), each (P,).

    A hypothesis' orientation is only as good as its three matched points, so each
    rendered skyline is first aligned to the photo's (:func:`align_skylines`): the
    score then judges the position, and refinement fixes the orientation.
    """
    if len(poses) == 0:
        return np.zeros(0), np.zeros(0)
    rendered, cols = strided_skylines(terrain, poses, intrinsics, stride, tol_px=0.5)
    score, agreement, *_ = align_skylines(rendered, image_skyline[cols], cols, intrinsics.cx, weights[cols],
                                          params=params)
    return score, agreement
