"""Stage 1b — the k nearest feature points of every pivot (major peak)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def k_nearest_features(pivot_xy: np.ndarray, feature_xy: np.ndarray, pivot_index: np.ndarray, k: int = 15) -> np.ndarray:
    """Indices (into the feature table) of each pivot's k nearest other feature points.

    Parameters
    ----------
    pivot_xy : (P, 2) pivot positions (m); pivot_index : (P,) their rows in the feature table.
    feature_xy : (F, 2) all feature point positions (m).
    k : neighbours per pivot (fewer exist when F - 1 < k: the rest is -1).

    Returns (P, k) int64, nearest first (horizontal distance), the pivot itself excluded.
    """
    n = len(feature_xy)
    want = min(k + 1, n)
    if n == 0 or len(pivot_xy) == 0:
        return np.full((len(pivot_xy), k), -1, dtype=np.int64)
    _, idx = cKDTree(feature_xy).query(pivot_xy, k=want)
    idx = np.asarray(idx).reshape(len(pivot_xy), want)
    out = np.full((len(pivot_xy), k), -1, dtype=np.int64)
    for i, row in enumerate(idx):  # drop the pivot itself (it is its own nearest)
        row = row[row != pivot_index[i]][:k]
        out[i, : len(row)] = row
    return out


def most_covisible_features(together: np.ndarray, feature_xy: np.ndarray, k: int = 15) -> np.ndarray:
    """Indices of each feature point's k most often co-visible other feature points.

    Parameters
    ----------
    together : (F, F) counts of model viewpoints that see both points as skyline
        features (:class:`~skyrender.model.covisibility.Covisibility`), i.e. P(j | i)
        up to a per-row factor.
    feature_xy : (F, 2) positions (m): ties in the counts go to the nearer point.
    k : neighbours per point; fewer where fewer are ever seen together (the rest is -1).

    Returns (F, k) int64, most co-visible first, the point itself excluded.
    """
    together = np.asarray(together, np.float64)
    n = len(together)
    out = np.full((n, k), -1, dtype=np.int64)
    if n < 2:
        return out
    xy = np.asarray(feature_xy, np.float64)
    dist = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    counts = together.copy()
    np.fill_diagonal(counts, 0.0)
    order = np.lexsort((dist, -counts), axis=1)[:, :k]  # by count, then distance
    seen = np.take_along_axis(counts, order, axis=1) > 0
    out[:, : order.shape[1]] = np.where(seen, order, -1)
    return out
