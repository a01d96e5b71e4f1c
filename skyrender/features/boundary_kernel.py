"""The compiled kernel of :func:`skyrender.features.skyline.boundary_dp` (numba, cached on disk): the minimum-cost
path's column-by-column recursion with numpy's operations in their order, so the same path and costs to the bit,
without numpy's ~20 calls per column (a 1,024-wide photo's five boundary searches took ~0.2 s of the extractor's
time in them). Its own module so that numba's on-disk cache finds it, and so that numba is imported only when a
skyline is extracted."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(nogil=True, cache=True)
def _minimum(x, y):
    """np.minimum of two floats: the smaller, NaN if either is, the first of equals."""
    if np.isnan(y):
        return y
    return y if y < x else x


@numba.njit(nogil=True, cache=True)
def boundary_path(columns, slope, jump_cap):
    """The path of :func:`~skyrender.features.skyline.boundary_dp`: ``columns`` (W, n) float64 costs (a column's rows
    contiguous), ``slope`` (n,) = jump_cost * row, ``jump_cap`` the transition cost's cap. Per column, the best
    predecessor from above (b' <= b: running minima of d - slope, the last row attaining one) and from below
    (b' >= b: of d + slope from the bottom row up), the one from above where they tie, and the column's best row
    where the capped jump costs less; then the path traced back. Returns (W,) int64 rows."""
    W, n = columns.shape
    back = np.zeros((W, n), np.int32)
    d = columns[0].copy()
    g1, g2 = np.empty(n), np.empty(n)
    a1, a2 = np.empty(n, np.int64), np.empty(n, np.int64)
    for j in range(1, W):
        m, a = 0.0, 0  # m set by the first row
        for b in range(n):  # from above
            h = d[b] - slope[b]
            m = h if b == 0 else _minimum(m, h)
            if h <= m:
                a = b
            g1[b], a1[b] = m + slope[b], a
        m, a = 0.0, 0
        for k in range(n):  # from below, the bottom row first
            b = n - 1 - k
            h = d[b] + slope[b]
            m = h if k == 0 else _minimum(m, h)
            if h <= m:
                a = k
            g2[b], a2[b] = m - slope[b], n - 1 - a
        best = np.argmin(d)
        far = d[best] + jump_cap
        for b in range(n):
            g = _minimum(g1[b], g2[b])
            back[j, b] = best if far < g else (a1[b] if g1[b] <= g2[b] else a2[b])
            d[b] = _minimum(g, far) + columns[j, b]
    path = np.empty(W, np.int64)
    path[W - 1] = np.argmin(d)
    for j in range(W - 1, 0, -1):
        path[j - 1] = back[j, path[j]]
    return path


def compile_now() -> None:
    """Compile :func:`boundary_path` for the argument types the extractor passes it, into numba's on-disk cache
    (``make install`` runs ``python -m skyrender.features.boundary_kernel``)."""
    boundary_path(np.zeros((2, 3)), np.arange(3.0), 1.0)


if __name__ == "__main__":
    compile_now()
