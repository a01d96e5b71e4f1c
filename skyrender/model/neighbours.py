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
