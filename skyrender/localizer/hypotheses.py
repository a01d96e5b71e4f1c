"""Stage 3a — hypotheses (Naval 2000, sections 2.3–2.4).

A hypothesis matches an image triple (three skyline peaks, ordered left to
right) with a model triple (a pivot and two of its k nearest feature points) in
one of the 3! assignments. Hypotheses are ranked most probable first by
P(pivot) P(j | pivot) P(k | pivot) (the learned co-visibility, with add-one
smoothing so unseen pairs come last rather than never) times the image
triple's weight (the geometric mean of its peaks' sizes, relative to the largest).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations, permutations

import numpy as np

from ..model import Model

PERMUTATIONS = np.array(list(permutations(range(3))), dtype=np.int64)  # (6, 3)


@dataclass(frozen=True)
class Hypotheses:
    """N hypotheses, most probable first (unless generated unordered).

    image : (N, 3) indices of the image peaks, left to right.
    features : (N, 3) feature-table rows matched to them.
    log_p : (N,) log of the ranking probability.
    """

    image: np.ndarray
    features: np.ndarray
    log_p: np.ndarray

    def __len__(self) -> int:
        return len(self.log_p)

    def take(self, index) -> "Hypotheses":
        return Hypotheses(self.image[index], self.features[index], self.log_p[index])


def image_triples(peak_u: np.ndarray, peak_size: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All triples of image peaks, each ordered left to right, and their log weights.

    peak_u, peak_size : (n,) apex columns (px) and sizes (px^2).
    Returns (T, 3) indices and (T,) log weights (geometric mean size over the largest).
    """
    n = len(peak_u)
    if n < 3:
        return np.zeros((0, 3), np.int64), np.zeros(0)
    tri = np.array(list(combinations(range(n), 3)), dtype=np.int64)
    tri = np.take_along_axis(tri, np.argsort(np.asarray(peak_u)[tri], axis=1), axis=1)
    size = np.maximum(np.asarray(peak_size, np.float64), 1e-9)
    log_w = np.log(size[tri]).mean(axis=1) - np.log(size.max())
    return tri, log_w


def model_triples(model: Model, pivot_positions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(M, 3) feature rows (pivot, j, k) with j, k two of the pivot's k nearest, and
    (M,) log P(pivot) P(j | pivot) P(k | pivot) with add-one smoothing.

    pivot_positions : indices into ``model.pivots`` allowed (a prior); default all.
    """
    pivots = model.pivots
    allowed = np.arange(len(pivots)) if pivot_positions is None else np.asarray(pivot_positions, np.int64)
    cov = model.covisibility
    n = cov.n_viewpoints
    seen = cov.seen[pivots].astype(np.float64)
    nb = model.neighbours  # (P, k), -1 = none
    together = np.where(nb >= 0, np.take_along_axis(cov.together, np.maximum(nb, 0), axis=1), 0)
    log_pivot = np.log((seen + 1.0) / (n + 2.0))
    log_cond = np.log((together + 1.0) / (seen[:, None] + 2.0))
    k = nb.shape[1]
    pairs = np.array(list(combinations(range(k), 2)), dtype=np.int64)  # (C, 2)
    rows, logs = [], []
    for p in allowed:
        valid = (nb[p, pairs[:, 0]] >= 0) & (nb[p, pairs[:, 1]] >= 0)
        pr = pairs[valid]
        rows.append(np.column_stack([np.full(len(pr), pivots[p]), nb[p, pr[:, 0]], nb[p, pr[:, 1]]]))
        logs.append(log_pivot[p] + log_cond[p, pr[:, 0]] + log_cond[p, pr[:, 1]])
    if not rows:
        return np.zeros((0, 3), np.int64), np.zeros(0)
    return np.concatenate(rows).astype(np.int64), np.concatenate(logs)


def generate_hypotheses(peak_u: np.ndarray, peak_size: np.ndarray, model: Model,
                        pivot_positions: np.ndarray | None = None, ordered: bool = True,
                        seed: int = 0) -> Hypotheses:
    """Every (image triple x model triple x assignment), most probable first.

    ``ordered=False`` gives the same set in a seeded arbitrary order (the
    baseline without the probabilistic ordering).
    """
    itri, log_w = image_triples(peak_u, peak_size)
    mtri, log_m = model_triples(model, pivot_positions)
    T, M, A = len(itri), len(mtri), len(PERMUTATIONS)
    if T == 0 or M == 0:
        return Hypotheses(np.zeros((0, 3), np.int64), np.zeros((0, 3), np.int64), np.zeros(0))
    ti, mi, ai = (g.ravel() for g in np.meshgrid(np.arange(T), np.arange(M), np.arange(A), indexing="ij"))
    log_p = log_w[ti] + log_m[mi]
    order = np.argsort(-log_p, kind="stable") if ordered else np.random.default_rng(seed).permutation(len(log_p))
    ti, mi, ai = ti[order], mi[order], ai[order]
    features = np.take_along_axis(mtri[mi], PERMUTATIONS[ai], axis=1)
    return Hypotheses(itri[ti], features, log_p[order])
