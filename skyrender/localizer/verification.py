"""Stage 4a — verification: render each surviving pose's skyline and score it
against the photo's skyline (Naval 2000, section 2.6, with a robust score).

Per column, e = rendered v - photo v (px). Terrain where the photo shows sky
(e < 0) is a plain error. Photo skyline above the terrain (e > 0) may be a
foreground occluder (a tree, a post), so it costs only ``occluder_weight`` of
that. Errors are capped (one bad column cannot dominate) and weighted by the
photo's per-column confidence. The score is the weighted mean cost (px); the
agreement is the weighted share of columns within ``agree_px``.

A hypothesis' position is only known to a few hundred metres (its three matched
apexes are noisy), and a skyline ridge r metres away moves by about f * 300 m / r
px for such an error: near ridges say nothing yet. So the verification counts a
column in full only where the rendered skyline lies beyond ``trust_far_m`` (not
at all nearer than ``trust_near_m``, linearly between), and charges the rest
``untrusted_px``: a pose whose whole skyline is near has no evidence for it.
On four benchmark views with a near-truth hypothesis this ranked one first in
each, where the plain score ranked view 5's 3,226th of 9,304; but it ranks a view
whose own skyline is near poorly, so :func:`verify_poses` gives both scores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..blocks import in_blocks
from ..camera import Intrinsics
from ..render import Terrain
from ..render.skyline import strided_skylines

#: Horizontal shifts (px) tried when aligning a rendered skyline to the photo's.
SHIFTS_PX = np.arange(-30.0, 30.01, 1.0)
#: Poses per block of :func:`align_skylines` (blocks run on all cores, their arrays small enough
#: to stay in the cache).
ALIGN_BLOCK_ROWS = 128
#: ... and at least this many elements each (numpy's sums over rows of smaller arrays can differ
#: in the last bit from a larger array's).
MIN_BLOCK_ELEMENTS = 1 << 16


@dataclass(frozen=True)
class ScoreParams:
    cap_px: float = 20.0
    occluder_weight: float = 0.25
    agree_px: float = 2.0
    trust_near_m: float = 500.0  # verification only: rendered skyline nearer than this is not counted...
    trust_far_m: float = 4000.0  # ... and counts in full beyond this
    untrusted_px: float = 1.0  # ... the cost of a column not counted
    # the camera's roll (swing, deg) the alignment and the least squares may reach: inf for renders
    # (any roll); hand-held photos stand nearly upright (the oracle fits of the CH1 training photos:
    # -5.4..3.0 deg), and wrong places fitted with 10-50 deg of roll (experiments/ch1/README.md)
    max_swing_deg: float = math.inf


def column_errors(rendered: np.ndarray, image: np.ndarray, cap_px: float) -> np.ndarray:
    """(..., W) rendered - image (px); a column where exactly one of them is NaN
    (sky only) counts as -cap (terrain missing or extra is never an occluder), both NaN as 0."""
    e = np.asarray(rendered - image)
    rendered_nan = np.isnan(rendered)
    np.copyto(e, -cap_px, where=rendered_nan)  # where the image has a skyline; its own NaN columns next
    image_nan = np.isnan(image)
    if image_nan.any():  # few columns: those of the photo's skyline that see only sky
        e[..., image_nan] = np.where(np.broadcast_to(rendered_nan, e.shape)[..., image_nan], 0.0, -cap_px)
    return e


def score_skylines(rendered: np.ndarray, image: np.ndarray, weights: np.ndarray,
                   params: ScoreParams = ScoreParams(),
                   trust: np.ndarray | None = None, agreement: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Robust score (px, lower is better) and agreement share of rendered skylines
    (P, W) against the photo's (W,), with per-column weights (W,) in [0, 1]; a
    column's ``trust`` ((P, W) in [0, 1]; None: all 1) counts its cost, the rest of it
    costs ``params.untrusted_px``. With ``agreement`` False the share is not computed (None)."""
    e = column_errors(rendered, image, params.cap_px)
    size = np.abs(e)
    cost = np.minimum(size, params.cap_px)
    np.multiply(cost, params.occluder_weight, out=cost, where=e >= 0)  # photo skyline above: maybe an occluder
    total = max(float(np.sum(weights)), 1e-9)
    if trust is not None:
        cost = trust * cost + (1.0 - trust) * params.untrusted_px
    score = (cost * weights).sum(axis=-1) / total
    if not agreement:
        return score, None
    agree = size <= params.agree_px
    if trust is not None:
        agree = agree * trust
    return score, (agree * weights).sum(axis=-1) / total


def part_margins(rendered: np.ndarray, image: np.ndarray, weights: np.ndarray, parts: int = 2,
                 params: ScoreParams = ScoreParams()) -> np.ndarray:
    """(parts,) the first rendered skyline's margin over the others on each of ``parts`` equal
    stretches of columns, left to right: 1 - its score / the best other's score
    (:func:`score_skylines` with the other columns' weights set to 0), rendered (P >= 2, W).
    Positive where the first fits that stretch better than every other; a look-alike that wins
    the whole skyline on the strength of one stretch has a negative margin on another."""
    W = rendered.shape[1]
    stretch = np.minimum((np.arange(W) * parts) // W, parts - 1)
    scores = np.column_stack([score_skylines(rendered, image, weights * (stretch == k), params)[0]
                              for k in range(parts)])  # (P, parts)
    return 1.0 - scores[0] / np.maximum(scores[1:].min(axis=0), 1e-9)


def trust_of_distance(distance: np.ndarray, params: ScoreParams = ScoreParams()) -> np.ndarray:
    """How far a rendered skyline column counts, from the distance (m) of its terrain:
    0 nearer than ``trust_near_m``, 1 beyond ``trust_far_m``, linear between."""
    span = max(params.trust_far_m - params.trust_near_m, 1e-9)
    return np.clip((np.asarray(distance, np.float64) - params.trust_near_m) / span, 0.0, 1.0)


def align_skylines(rendered: np.ndarray, image: np.ndarray, columns: np.ndarray, cx: float, weights: np.ndarray,
                   shifts: np.ndarray = SHIFTS_PX, params: ScoreParams = ScoreParams(),
                   trust: np.ndarray | None = None, coarse: int = 3, swing: np.ndarray | None = None,
                   agreement: bool = True):
    """Best 2-D alignment of rendered skylines (P, n) to the photo's (n,), both sampled
    at image columns ``columns`` (u = column + 0.5): the rendered curve moved right by
    ``a`` px and by ``b + c (u - cx)`` px down, a from ``shifts`` (evenly spaced), b and
    c by weighted least squares. ``trust`` (P, n) in [0, 1]: how far each rendered
    column counts (:func:`trust_of_distance`; None: all in full); it moves with its
    column. Every ``coarse``-th shift is tried first, then the shifts around each
    pose's best (on rendered skylines sampled every few px the score is smooth in a).
    ``swing`` (P,) deg: the poses' roll (None: 0); the slope c is kept to what leaves it
    within ``params.max_swing_deg`` (:func:`slope_bounds`).
    Returns (score, agreement, a, b, c), each (P,); the agreement None unless ``agreement``
    (it costs a pass of its own, and the localizer ranks by the score).

    Every operation is row-wise, so many poses are aligned in blocks of
    :data:`ALIGN_BLOCK_ROWS` on all cores (2-3x faster on 2 cores: a CH1 photo's 4,077
    far-horizon poses, a refinement level's 600 poses), with the whole arrays' values to the bit: numpy's row sums of an array
    under 2**16 elements can differ in the last bit from those of a larger one, so every block
    holds at least that many (the last one padded with its last row). A block's shifts are tried by
    a compiled kernel (:func:`_compiled_fits`) that gives numpy's values to the bit: on a CH1 photo
    with the fov unknown the alignments took 10.9 s in numpy's passes and 3.5 s so
    (experiments/ch1/compiled-alignment/). Fewer poses than a block go through numpy's passes.
    """
    P = len(rendered)
    rendered = np.asarray(rendered, np.float32)  # float32: the alignment is the verification's hot path
    trust = None if trust is None else np.asarray(trust, np.float32)
    swing = np.zeros(P) if swing is None else np.asarray(swing, np.float64)
    per_block = max(ALIGN_BLOCK_ROWS, -(-MIN_BLOCK_ELEMENTS // max(rendered.shape[1], 1)))
    if P <= per_block:
        return _align_rows(rendered, image, columns, cx, weights, shifts, params, trust, coarse, swing, agreement)
    out = [np.empty(P) for _ in range(5)]
    if not agreement:
        out[1] = None

    def rows(lo: int, hi: int) -> None:
        take = np.minimum(np.arange(lo, lo + per_block), P - 1)  # the last block padded with its last row
        part = _align_rows(rendered[take], image, columns, cx, weights, shifts, params,
                           None if trust is None else trust[take], coarse, swing[take], agreement, compiled=True)
        for whole, values in zip(out, part):
            if whole is not None:
                whole[lo:hi] = values[: hi - lo]

    in_blocks(P, per_block, rows)
    return tuple(out)


def _align_rows(rendered: np.ndarray, image: np.ndarray, columns: np.ndarray, cx: float, weights: np.ndarray,
                shifts: np.ndarray, params: ScoreParams, trust: np.ndarray | None, coarse: int,
                swing: np.ndarray, agreement: bool = True, compiled: bool = False) -> tuple:
    """:func:`align_skylines` of some poses: ``rendered`` (P, n) float32, ``trust`` (P, n) float32
    or None, ``swing`` (P,) deg. With ``compiled`` the shifts (every ``coarse``-th, then those around each
    pose's best) are tried by :func:`_compiled_fits` (a block of :func:`align_skylines`, where it gives
    numpy's values), else by numpy's passes (:func:`_aligned_at`)."""
    shifts = np.asarray(shifts, np.float64)
    P = len(rendered)
    bounds = slope_bounds(swing, params.max_swing_deg)
    coarse = coarse if len(shifts) > 5 * coarse else 1

    def at(a):  # the agreement only at each pose's best shift, below
        score, _, *abc = _aligned_at(rendered, image, columns, cx, weights, a, params, trust, bounds, agreement=False)
        return score, *abc

    if compiled:
        best = _compiled_fits(rendered, image, columns, cx, weights, shifts[::coarse], params, trust, bounds)
    else:
        best = (np.full(P, np.inf), np.zeros(P), np.zeros(P), np.zeros(P))  # score, a, b, c
        for a in shifts[::coarse]:
            best = _better(best, at(a))
    if coarse > 1:
        step = shifts[1] - shifts[0]
        around = [np.clip(best[1] + k * step, shifts[0], shifts[-1]) for k in range(1 - coarse, coarse) if k]
        if compiled:
            best = _compiled_fits(rendered, image, columns, cx, weights, np.column_stack(around), params, trust,
                                  bounds, best)
        else:
            for a in around:
                best = _better(best, at(a))
    share = None
    if agreement:  # at each pose's best shift: the same fit, its agreement (indexed otherwise: to the last bits)
        share = _aligned_at(rendered, image, columns, cx, weights, best[1], params, trust, bounds)[1]
    return best[0], share, *best[1:]


def slope_bounds(swing: np.ndarray, max_swing_deg: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(low, high) (P,) of the alignment slope c for poses of roll ``swing`` (P,) deg: a slope c
    turns a pose's swing by -atan(c) (:func:`skyrender.localizer.refinement.realigned`), so these
    keep it within +-``max_swing_deg``; None when unbounded."""
    if not math.isfinite(max_swing_deg):
        return None
    swing = np.asarray(swing, np.float64)
    lim = np.radians(max_swing_deg)
    return (np.tan(np.clip(np.radians(swing) - lim, -1.5, 1.5)).astype(np.float32),
            np.tan(np.clip(np.radians(swing) + lim, -1.5, 1.5)).astype(np.float32))


def _better(best: tuple, new: tuple) -> tuple:
    """Per pose, the (score, ...) tuple with the lower score."""
    improved = new[0] < best[0]
    return tuple(np.where(improved, n, o) for n, o in zip(new, best))


def _aligned_at(rendered: np.ndarray, image: np.ndarray, columns: np.ndarray, cx: float, weights: np.ndarray,
                a: np.ndarray, params: ScoreParams, trust: np.ndarray | None, bounds: tuple | None = None,
                agreement: bool = True) -> tuple:
    """:func:`align_skylines` at one shift ``a`` (px; a float, or one per pose (P,)), the slope
    within ``bounds`` (:func:`slope_bounds`; None: free): (score, agreement, a, b, c), each (P,)
    (the agreement None unless ``agreement``)."""
    u = columns + 0.5
    n = len(u)
    step = u[1] - u[0] if n > 1 else 1.0
    x = (u - cx).astype(np.float32)
    # rendered value at u - a, linear between samples (NaN stays NaN)
    pos = (u - np.asarray(a, np.float64)[..., None] - u[0]) / step
    i0 = np.clip(np.floor(pos).astype(np.int64), 0, n - 1)
    i1 = np.minimum(i0 + 1, n - 1)
    t = np.clip(pos - i0, 0.0, 1.0).astype(np.float32)

    def at_shift(values):
        if np.ndim(a) == 0:  # one shift for all: plain column indexing, much cheaper than a gather
            return values[:, i0] * (1 - t) + values[:, i1] * t
        return np.take_along_axis(values, i0, 1) * (1 - t) + np.take_along_axis(values, i1, 1) * t

    moved = at_shift(rendered)
    outside = (pos < 0) | (pos > n - 1)
    if np.ndim(a) == 0:
        moved[:, outside] = np.nan
    else:
        moved[outside] = np.nan
    trusted = None if trust is None else at_shift(trust)
    d = image[None, :].astype(np.float32) - moved
    finite = np.isfinite(d)
    w = weights[None, :].astype(np.float32) * (1.0 if trusted is None else trusted)
    w = np.where(finite, w, np.float32(0.0))
    d0 = np.where(finite, d, np.float32(0.0))
    # robust line fit: least squares, then again without the columns beyond 3 px
    for fit in range(2):
        wx = w * x
        sw, sx, sxx = w.sum(1), wx.sum(1), (wx * x).sum(1)
        sy, sxy = (w * d0).sum(1), (wx * d0).sum(1)
        det = np.maximum(sw * sxx - sx * sx, 1e-9)
        c = (sw * sxy - sx * sy) / det
        if bounds is not None:  # the best offset for the bounded slope
            c = np.clip(c, *bounds)
        b = (sy - c * sx) / np.maximum(sw, 1e-9)
        if fit == 0:
            w = np.where(np.abs(d0 - b[:, None] - c[:, None] * x) <= 3.0, w, np.float32(0.0))
    score, agreement = score_skylines(moved + b[:, None] + c[:, None] * x, image, weights, params, trusted,
                                      agreement=agreement)
    return score, agreement, np.broadcast_to(np.asarray(a, np.float64), score.shape), b.astype(np.float64), \
        c.astype(np.float64)


def _compiled_fits(rendered: np.ndarray, image: np.ndarray, columns: np.ndarray, cx: float, weights: np.ndarray,
                   shifts: np.ndarray, params: ScoreParams, trust: np.ndarray | None, bounds: tuple | None,
                   best: tuple | None = None) -> tuple:
    """:func:`_aligned_at` at each of ``shifts`` in turn, the best kept per pose (the first of equals), from
    ``best`` ((score, a, b, c), each (P,); None: none yet): the new best. ``shifts`` (S,) px are tried on
    every pose, (P, S) one row per pose. Compiled (numba), 6-10x faster than numpy's passes.

    It does numpy's float32 and float64 operations in their order, and sums as numpy sums the arrays
    :func:`_aligned_at` makes: one shift for all indexes the columns into column-major arrays, whose rows
    numpy sums from the first column on; a shift per pose gathers row-major arrays, which numpy sums pairwise.
    So in blocks of :func:`align_skylines` (2**16 elements or more) its values are numpy's to the bit
    (tested); numpy lays smaller arrays out otherwise now and then."""
    from .alignment_kernel import best_fits  # numba: imported, and compiled or loaded from its cache, on first use

    P, n = rendered.shape
    shifts = np.asarray(shifts, np.float64)
    per_pose = shifts.ndim == 2
    u = (columns + 0.5).astype(np.float64)
    low, high = bounds if bounds is not None else (np.zeros(P, np.float32),) * 2
    if best is None:
        best = (np.full(P, np.inf), np.zeros(P), np.zeros(P), np.zeros(P))
    score, a = best[0].copy(), best[1].copy()
    b, c = best[2].astype(np.float32), best[3].astype(np.float32)
    # contiguous arrays throughout: the argument types alignment_kernel.compile_now compiles for
    best_fits(np.ascontiguousarray(rendered, np.float32),
              np.zeros((0, n), np.float32) if trust is None else np.ascontiguousarray(trust, np.float32),
              np.ascontiguousarray(image, np.float32), np.ascontiguousarray(image, np.float64),
              np.ascontiguousarray(weights, np.float32), np.ascontiguousarray(weights, np.float64), u,
              (u - cx).astype(np.float32), np.ascontiguousarray(np.atleast_2d(shifts)), per_pose,
              np.ascontiguousarray(low), np.ascontiguousarray(high), bounds is not None, float(params.cap_px),
              float(params.occluder_weight), float(params.untrusted_px), max(float(np.sum(weights)), 1e-9),
              score, a, b, c)
    return score, a, b.astype(np.float64), c.astype(np.float64)


def verify_poses(terrain: Terrain, poses: np.ndarray, intrinsics: Intrinsics, image_skyline: np.ndarray,
                 weights: np.ndarray, stride: int = 4,
                 params: ScoreParams = ScoreParams()) -> tuple[np.ndarray, np.ndarray]:
    """Score many poses (P, 6) on every ``stride``-th column; returns (score, trusted
    score), each (P, ) px: the plain score, and the one that counts far skyline only
    (:func:`trust_of_distance`). Neither ranks right candidates first on every view
    (the trusted one lost a view whose skyline is near), so the localizer takes both.

    A hypothesis' orientation is only as good as its three matched points, so each
    rendered skyline is first aligned to the photo's (:func:`align_skylines`): the
    score then judges the position, and refinement fixes the orientation.
    """
    if len(poses) == 0:
        return np.zeros(0), np.zeros(0)
    rendered, distance, cols = strided_skylines(terrain, poses, intrinsics, stride, tol_px=0.5, with_distance=True)
    image, w = image_skyline[cols], weights[cols]
    swing = np.asarray(poses, np.float64)[:, 5]
    score, *_ = align_skylines(rendered, image, cols, intrinsics.cx, w, params=params, swing=swing, agreement=False)
    trusted, *_ = align_skylines(rendered, image, cols, intrinsics.cx, w, params=params, agreement=False,
                                 trust=trust_of_distance(distance, params), swing=swing)
    return score, trusted
