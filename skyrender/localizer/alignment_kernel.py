"""The compiled kernel of :func:`skyrender.localizer.verification._compiled_fits` (numba, cached on disk):
:func:`~skyrender.localizer.verification.align_skylines`' least-squares fits and scores, shift by shift, in
numpy's operations and summation orders. Its own module so that numba's on-disk cache finds it, and so that
numba is imported only by a localization."""

from __future__ import annotations

import numba
import numpy as np

f32 = np.float32


@numba.njit(nogil=True, cache=True)
def block_sum(values, lo, n, zero):
    """numpy's pairwise sum of values[lo:lo + n] for n <= 128: eight running sums, then the rest."""
    if n < 8:
        total = zero
        for i in range(lo, lo + n):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[lo], values[lo + 1], values[lo + 2], values[lo + 3]
    r4, r5, r6, r7 = values[lo + 4], values[lo + 5], values[lo + 6], values[lo + 7]
    i = lo + 8
    while i < lo + n - n % 8:
        r0 += values[i]
        r1 += values[i + 1]
        r2 += values[i + 2]
        r3 += values[i + 3]
        r4 += values[i + 4]
        r5 += values[i + 5]
        r6 += values[i + 6]
        r7 += values[i + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < lo + n:
        total += values[i]
        i += 1
    return total


@numba.njit(nogil=True, cache=True)
def pairwise(values, lo, n, zero):
    """numpy's pairwise sum of values[lo:lo + n] (its float add reduction over a contiguous row): blocks of at
    most 128 (:func:`block_sum`), halves of a multiple of 8 added. Its recursion walked with a stack of its
    own: numba's cache of a recursive function crashed the next process that loaded it."""
    if n <= 128:
        return block_sum(values, lo, n, zero)
    start = np.empty(64, np.int64)
    size = np.empty(64, np.int64)
    state = np.empty(64, np.int64)  # 0: neither half summed, 1: the left one, 2: both
    left = np.empty(64, values.dtype)
    top, total = 0, zero
    start[0], size[0], state[0] = lo, n, 0
    while top >= 0:
        if size[top] <= 128:
            total = block_sum(values, start[top], size[top], zero)
            top -= 1
            continue
        half = size[top] // 2
        half -= half % 8
        if state[top] == 0:
            state[top] = 1
            start[top + 1], size[top + 1], state[top + 1] = start[top], half, 0
            top += 1
        elif state[top] == 1:
            left[top], state[top] = total, 2
            start[top + 1], size[top + 1], state[top + 1] = start[top] + half, size[top] - half, 0
            top += 1
        else:
            total = left[top] + total
            top -= 1
    return total


@numba.njit(nogil=True, cache=True)
def row_sum(values, in_pairs, zero):
    """numpy's sum of a row: pairwise (row-major arrays), or from the first value on (column-major)."""
    if in_pairs:
        return pairwise(values, 0, len(values), zero)
    total = values[0]
    for i in range(1, len(values)):
        total += values[i]
    return total

@numba.njit(nogil=True, cache=True)
def best_fits(rendered, trust, image32, image, weights32, weights, u, x, shifts, per_pose, low, high, bounded,
           cap, occluder_weight, untrusted, total, score, a_out, b_out, c_out):
    """For each pose p (row of ``rendered`` (P, n) float32, skylines sampled at image columns u - 0.5 (n,)), each
    shift of ``shifts`` (1, S) for all or (P, S) per pose (``per_pose``) px in turn: the rendered skyline moved
    right by it, offset b + slope c (about the image centre: ``x`` = u - cx, float32) fitted to the photo's
    skyline ``image`` (n,) by weighted least squares twice (the second time without the columns beyond 3 px), the
    slope within [``low``, ``high``] (P,) when ``bounded``; then the robust score of
    :func:`~skyrender.localizer.verification.score_skylines` (``cap``, ``occluder_weight``, ``untrusted``; column
    weights ``weights`` (n,) summing to ``total``; ``trust`` (P, n) float32, or (0, n) for none). Where a shift scores
    lower than ``score[p]``, it and its fit replace ``score``, ``a_out``, ``b_out``, ``c_out`` (P,) in place. Every
    operation is numpy's in :func:`~skyrender.localizer.verification._aligned_at`, in its order and precision; the
    sums pairwise with ``per_pose``, else from the first column on (numpy's summation of the arrays it makes)."""
    P, n = rendered.shape
    with_trust = trust.shape[0] > 0
    tiny, three, one, untrusted32 = f32(1e-9), f32(3.0), f32(1.0), f32(untrusted)
    step = u[1] - u[0] if n > 1 else 1.0
    moved = np.empty(n, np.float32)
    trusted = np.empty(n, np.float32)
    d0 = np.empty(n, np.float32)
    w = np.empty(n, np.float32)
    terms = np.empty((5, n), np.float32)
    cost = np.empty(n, np.float64)
    zero32, zero64 = f32(0.0), 0.0
    for p in range(P):
        row = p if per_pose else 0
        for s in range(shifts.shape[1]):
            shift = shifts[row, s]
            for j in range(n):  # the rendered skyline moved right by the shift, linear between samples
                pos = (u[j] - shift - u[0]) / step
                j0 = min(max(int(np.floor(pos)), 0), n - 1)
                j1 = min(j0 + 1, n - 1)
                t = f32(min(max(pos - j0, 0.0), 1.0))
                m = rendered[p, j0] * (one - t) + rendered[p, j1] * t
                moved[j] = np.float32(np.nan) if pos < 0 or pos > n - 1 else m
                trusted[j] = trust[p, j0] * (one - t) + trust[p, j1] * t if with_trust else one
                d = image32[j] - moved[j]
                finite = np.isfinite(d)
                w[j] = (weights32[j] * trusted[j] if with_trust else weights32[j]) if finite else zero32
                d0[j] = d if finite else zero32
            b = c = zero32
            for fit in range(2):  # offset b + slope c by least squares, then without the columns beyond 3 px
                for j in range(n):
                    wx = w[j] * x[j]
                    terms[0, j], terms[1, j], terms[2, j] = w[j], wx, wx * x[j]
                    terms[3, j], terms[4, j] = w[j] * d0[j], wx * d0[j]
                sw, sx, sxx = row_sum(terms[0], per_pose, zero32), row_sum(terms[1], per_pose, zero32), \
                    row_sum(terms[2], per_pose, zero32)
                sy, sxy = row_sum(terms[3], per_pose, zero32), row_sum(terms[4], per_pose, zero32)
                c = (sw * sxy - sx * sy) / max(sw * sxx - sx * sx, tiny)
                if bounded:
                    c = min(max(c, low[p]), high[p])
                b = (sy - c * sx) / max(sw, tiny)
                if fit == 0:
                    for j in range(n):
                        if not abs(d0[j] - b - c * x[j]) <= three:
                            w[j] = zero32
            for j in range(n):  # score_skylines
                r = moved[j] + b + c * x[j]
                e = np.float64(r) - image[j]
                if np.isnan(r) or np.isnan(image[j]):
                    e = 0.0 if np.isnan(r) and np.isnan(image[j]) else -cap
                cost_j = min(abs(e), cap)
                if e >= 0:
                    cost_j = cost_j * occluder_weight
                if with_trust:
                    cost_j = np.float64(trusted[j]) * cost_j + np.float64((one - trusted[j]) * untrusted32)
                cost[j] = cost_j * weights[j]
            value = row_sum(cost, per_pose, zero64) / total
            if value < score[p]:
                score[p], a_out[p], b_out[p], c_out[p] = value, shift, b, c


def compile_now() -> None:
    """Compile :func:`best_fits` for the argument types the verification passes it, into numba's on-disk cache
    (``make install`` runs ``python -m skyrender.localizer.alignment_kernel``): a localization then loads it in
    ~0.2 s instead of compiling it for ~4 s."""
    n = 8
    v32, v64 = np.zeros(n, np.float32), np.zeros(n)
    best_fits(np.zeros((1, n), np.float32), np.zeros((0, n), np.float32), v32, v64, v32, v64 + 1.0, np.arange(n) + 0.5,
              v32, np.zeros((1, 3)), False, np.zeros(1, np.float32), np.zeros(1, np.float32), False, 20.0, 0.25, 1.0,
              float(n), np.full(1, np.inf), np.zeros(1), np.zeros(1, np.float32), np.zeros(1, np.float32))


if __name__ == "__main__":
    compile_now()
