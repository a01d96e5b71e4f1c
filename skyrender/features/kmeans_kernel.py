"""The compiled step of :func:`skyrender.features.kmeans.kmeans_labels` (numba, cached on disk): each row's nearest
centre and every cluster's sum and count, in one pass over the rows, with numpy's operations in their order (the
distances |c|^2 - 2 x.c from the same BLAS products, the first centre on a tie, the sums added in row order as
``np.bincount`` adds them), so the same labels and centres to the bit, without ~10 numpy calls a Lloyd step (4x
faster). Its own module, as :mod:`.boundary_kernel`, so that numba's on-disk cache finds it."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(nogil=True, cache=True)
def assign_and_sum(cross, norms, x):
    """``cross`` (N, k) = x @ centres.T, ``norms`` (k,) = |centre|^2, ``x`` (N, D) the rows. Returns (labels (N,)
    int64: the centre of least norms - 2 cross, the first of equals; sums (k, D) of each cluster's rows, added in
    row order; counts (k,) float64)."""
    N, k = cross.shape
    D = x.shape[1]
    labels = np.empty(N, np.int64)
    sums = np.zeros((k, D))
    counts = np.zeros(k)
    for i in range(N):
        nearest = 0
        least = norms[0] - 2.0 * cross[i, 0]
        for j in range(1, k):
            distance = norms[j] - 2.0 * cross[i, j]
            if distance < least:
                least, nearest = distance, j
        labels[i] = nearest
        counts[nearest] += 1.0
        for d in range(D):
            sums[nearest, d] += x[i, d]
    return labels, sums, counts


def compile_now() -> None:
    """Compile :func:`assign_and_sum` for the argument types :func:`~skyrender.features.kmeans.kmeans_labels` passes
    it, into numba's on-disk cache (``make install`` runs ``python -m skyrender.features.kmeans_kernel``)."""
    x = np.arange(6.0).reshape(3, 2)
    assign_and_sum(x @ x[:2].T, np.einsum("ij,ij->i", x[:2], x[:2]), x)


if __name__ == "__main__":
    compile_now()
