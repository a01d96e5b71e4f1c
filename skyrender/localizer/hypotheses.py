"""Stage 3a — hypotheses (Naval 2000, sections 2.3–2.4).

A hypothesis matches an image triple (three skyline peaks, ordered left to
right) with a model triple (an anchor feature point and two of its k
neighbours) in one of the 3! assignments. Ranked most probable first by
P(a) P(j | a) P(k | a) from the learned co-visibility (add-one smoothed) times
the image triple's weight (the geometric mean of its peaks' sizes, relative to
the largest).

Beyond the paper: every feature point anchors triples, not only the major
peaks (pivots) — on rendered test views only 15 of 40 had a pivot triple among
their matched peaks, 31 of 40 an anchor triple (k = 15). Triples with a pair
never seen together from any of the model's viewpoints are left out: that
halves them and lost no view in that test. An anchor's neighbours may also be
the k feature points most often seen together with it rather than its k nearest
(peaks seen together need not be near each other): see :func:`model_triples`.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations, permutations

import numpy as np

from ..model import Model
from ..model.neighbours import k_nearest_features, most_covisible_features

PERMUTATIONS = np.array(list(permutations(range(3))), dtype=np.int64)  # (6, 3)
#: How an anchor's partners in a model triple are chosen (:func:`model_triples`).
NEIGHBOURS = ("covisible", "nearest")


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


def model_triples(model: Model, neighbours: str = "nearest", k: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(M, 3) feature rows (a, j, k) — j, k two of anchor a's k neighbours — each
    set once, and (M,) log P(a) P(j | a) P(k | a) (add-one smoothed).

    neighbours : "nearest", the k nearest feature points (the paper's), or
        "covisible", the k most often seen together with a (:func:`most_covisible_features`).
        On 50 rendered views of ``make bench-localize``'s scene the model triples held a
        correct triple for 37 views (nearest, k = 15: 7,084 triples), 40 (covisible,
        k = 12: 10,780) and 42 (covisible, k = 15: 16,652); but more triples push the
        right one later, and end to end on the benchmark's 10 views "covisible"
        (k = 12 or 15, 1.2 M hypotheses) localized one view fewer, so "nearest" stays
        the default.
    k : neighbours per anchor (default: the model's k).
    Triples with a pair never co-visible in the model's statistics are dropped.
    """
    if neighbours not in NEIGHBOURS:
        raise ValueError(f"neighbours must be one of {NEIGHBOURS}, got {neighbours!r}")
    f = model.features
    F, k = len(f), min(model.params.k if k is None else k, len(f) - 1)
    if k < 2:
        return np.zeros((0, 3), np.int64), np.zeros(0)
    cov = model.covisibility
    if neighbours == "covisible":
        nb = most_covisible_features(cov.together, f.xyz[:, :2], k)  # (F, k), -1 = none
    else:
        nb = k_nearest_features(f.xyz[:, :2], f.xyz[:, :2], np.arange(F), k)
    pairs = np.array(list(combinations(range(k), 2)), dtype=np.int64)
    anchor = np.repeat(np.arange(F), len(pairs))
    j, kk = nb[:, pairs[:, 0]].ravel(), nb[:, pairs[:, 1]].ravel()
    tri = np.column_stack([anchor, j, kk])
    T = cov.together
    ok = (j >= 0) & (kk >= 0)
    tri = tri[ok]
    ok = (T[tri[:, 0], tri[:, 1]] > 0) & (T[tri[:, 0], tri[:, 2]] > 0) & (T[tri[:, 1], tri[:, 2]] > 0)
    tri = tri[ok]
    seen = cov.seen.astype(np.float64)
    a = tri[:, 0]
    log_p = (np.log((seen[a] + 1.0) / (cov.n_viewpoints + 2.0))
             + np.log((T[a, tri[:, 1]] + 1.0) / (seen[a] + 2.0)) + np.log((T[a, tri[:, 2]] + 1.0) / (seen[a] + 2.0)))
    # one row per set of three, with its best anchor's probability
    order = np.argsort(-log_p, kind="stable")
    _, first = np.unique(np.sort(tri[order], axis=1), axis=0, return_index=True)
    keep = order[np.sort(first)]
    return tri[keep].astype(np.int64), log_p[keep]


def generate_hypotheses(peak_u: np.ndarray, peak_size: np.ndarray, model: Model,
                        prior: np.ndarray | None = None, ordered: bool = True, seed: int = 0,
                        neighbours: str = "nearest", k: int | None = None,
                        prior_boost: float = 1000.0, limit: int | None = None) -> Hypotheses:
    """Every (image triple x model triple x assignment), most probable first.

    prior : optional (F,) bool, the feature points a prior says are in view: triples
        holding one come first (their log-probability raised by ``prior_boost``; the prior
        named peak may still not be among the photo's largest skyline peaks, so the others follow).
    ``ordered=False`` gives the same set in a seeded arbitrary order (the
    baseline without the probabilistic ordering).
    limit : only the first ``limit`` of that list (ordered): the same hypotheses, without
        materialising the whole list — on a 2 x 2-tile mosaic it has ~100 M entries (~9 GB).
    """
    itri, log_w = image_triples(peak_u, peak_size)
    mtri, log_m = model_triples(model, neighbours, k)
    if prior is not None:
        log_m = log_m + prior_boost * np.asarray(prior, bool)[mtri].any(axis=1)
    T, M, A = len(itri), len(mtri), len(PERMUTATIONS)
    if T == 0 or M == 0:
        return Hypotheses(np.zeros((0, 3), np.int64), np.zeros((0, 3), np.int64), np.zeros(0))
    if ordered and limit is not None and limit < T * M * A:
        ti, mi, ai, log_p = _best_pairs(log_w, log_m, -(-limit // A), A)
        ti, mi, ai, log_p = ti[:limit], mi[:limit], ai[:limit], log_p[:limit]
    else:
        ti, mi, ai = (g.ravel() for g in np.meshgrid(np.arange(T), np.arange(M), np.arange(A), indexing="ij"))
        log_p = log_w[ti] + log_m[mi]
        order = np.argsort(-log_p, kind="stable") if ordered else np.random.default_rng(seed).permutation(len(log_p))
        ti, mi, ai, log_p = ti[order], mi[order], ai[order], log_p[order]
        if limit is not None:
            ti, mi, ai, log_p = ti[:limit], mi[:limit], ai[:limit], log_p[:limit]
    features = np.take_along_axis(mtri[mi], PERMUTATIONS[ai], axis=1)
    return Hypotheses(itri[ti], features, log_p)


def _best_pairs(log_w: np.ndarray, log_m: np.ndarray, n_pairs: int, A: int):
    """The ``n_pairs`` most probable (image triple, model triple) pairs, each expanded to its
    ``A`` assignments: exactly the head of the stable sort of every (ti, mi, ai) by -log p
    (a pair's assignments share its probability and sit together in ``ai`` order; equal
    pairs keep their (ti, mi) order). Returns ti, mi, ai, log p, each (n_pairs * A,)."""
    pair_p = log_w[:, None] + log_m[None, :]  # (T, M); flat index ti * M + mi
    flat = pair_p.ravel()
    n_pairs = min(n_pairs, flat.size)
    threshold = -np.partition(-flat, n_pairs - 1)[n_pairs - 1]
    above = np.flatnonzero(flat > threshold)
    tied = np.flatnonzero(flat == threshold)[: n_pairs - len(above)]  # ties in flat-index order
    pick = np.concatenate([above, tied])
    pick = pick[np.lexsort((pick, -flat[pick]))]
    ti, mi = np.divmod(pick, len(log_m))
    return (np.repeat(ti, A), np.repeat(mi, A), np.tile(np.arange(A), len(pick)), np.repeat(flat[pick], A))
