"""k-means, as scikit-learn's ``KMeans(n_clusters, n_init=1, random_state=seed)`` runs it.

The colour mixtures (:func:`~skyrender.features.sky._fit_gmm`) start from k-means labels, as
scikit-learn's ``GaussianMixture`` does. Importing scikit-learn for that cost 0.8-1 s of every
fresh ``skyrender skyline`` and ``skyrender localize`` (``scipy.stats`` building its docstrings);
this is the same algorithm in numpy, step for step — greedy k-means++ seeding (2 + ln k trials a
centre, from ``numpy.random.RandomState(seed)``), Lloyd iterations on the data centred on its mean,
empty clusters moved to the points farthest from their centres, the stop on unchanged labels or a
total squared centre shift within 1e-4 of the mean feature variance — so it gives the same labels
(``tests/test_features.py`` checks them against scikit-learn's).
"""

from __future__ import annotations

import numpy as np

KMEANS_MAX_ITER = 300
KMEANS_TOL = 1e-4  # relative to the mean variance of the features


def kmeans_labels(samples: np.ndarray, n_clusters: int, seed: int) -> np.ndarray:
    """(N,) cluster label in [0, n_clusters) of each row of ``samples`` (N, D); deterministic for a seed."""
    x = np.array(samples, np.float64, order="C")  # a copy: centred below, for accurate distances
    tol = float(np.mean(np.var(x, axis=0))) * KMEANS_TOL
    x -= x.mean(axis=0)
    centres = _kmeans_plusplus(x, n_clusters, np.random.RandomState(seed))
    previous = np.full(len(x), -1)
    for _ in range(KMEANS_MAX_ITER):
        labels, sums, count = _assign(x, centres)
        new = _cluster_means(x, labels, centres, sums, count)
        shift = ((new - centres) ** 2).sum()
        centres = new
        if np.array_equal(labels, previous):
            return labels
        if shift <= tol:
            break
        previous = labels
    return _assign(x, centres)[0]  # the labels of the last centres


def _assign(x: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(labels (N,): each row's nearest centre, the first on a tie; sums (k, D) of each cluster's rows in row
    order; counts (k,) float64): the distances |c|^2 - 2 x.c from one matrix product, the rest compiled
    (:func:`.kmeans_kernel.assign_and_sum`)."""
    from .kmeans_kernel import assign_and_sum  # numba: imported, and compiled or loaded from its cache, on first use

    return assign_and_sum(x @ centres.T, np.einsum("ij,ij->i", centres, centres), x)


def _kmeans_plusplus(x: np.ndarray, k: int, rng: np.random.RandomState) -> np.ndarray:
    """(k, D) seeds: the first a uniformly drawn row, each next the best (least total squared
    distance to the nearest seed) of 2 + ln k rows drawn with probability ∝ that distance."""
    n = len(x)
    trials = 2 + int(np.log(k))
    weight = np.ones(n)
    norms = np.einsum("ij,ij->i", x, x)
    first = rng.choice(n, p=weight / weight.sum())
    seeds = [first]
    closest = _squared_distances(x[[first]], x, norms)[0]
    potential = closest @ weight
    for _ in range(1, k):
        candidates = np.searchsorted(np.cumsum(weight * closest), rng.uniform(size=trials) * potential)
        np.clip(candidates, None, n - 1, out=candidates)  # rounding can draw past the end
        distances = np.minimum(closest, _squared_distances(x[candidates], x, norms))
        potentials = distances @ weight.reshape(-1, 1)
        best = int(np.argmin(potentials))
        potential, closest = potentials[best], distances[best]
        seeds.append(candidates[best])
    return x[seeds]


def _squared_distances(a: np.ndarray, x: np.ndarray, x_norms: np.ndarray) -> np.ndarray:
    """(len(a), N) squared Euclidean distances, |a|^2 - 2 a.x + |x|^2, clipped at 0."""
    d = -2 * (a @ x.T)
    d += np.einsum("ij,ij->i", a, a)[:, None]
    d += x_norms[None, :]
    return np.maximum(d, 0, out=d)


def _cluster_means(x: np.ndarray, labels: np.ndarray, centres: np.ndarray, sums: np.ndarray,
                   count: np.ndarray) -> np.ndarray:
    """(k, D) mean of each cluster's rows from their ``sums`` (k, D, in row order) and ``count`` (k,); an empty
    cluster takes the row farthest from its own centre, one such row per empty cluster, from the cluster it left
    (``sums`` and ``count`` changed in place then)."""
    empty = np.flatnonzero(count == 0)
    if len(empty):
        farthest = np.argpartition(((x - centres[labels]) ** 2).sum(axis=1), -len(empty))[:-len(empty) - 1:-1]
        for cluster, row in zip(empty, farthest):
            sums[labels[row]] -= x[row]
            count[labels[row]] -= 1.0
            sums[cluster], count[cluster] = x[row], 1.0
    means = centres.copy()
    full = count > 0
    means[full] = sums[full] * (1.0 / count[full])[:, None]  # times the reciprocal, as scikit-learn does
    return means
