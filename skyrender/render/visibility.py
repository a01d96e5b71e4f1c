"""Line of sight: is the segment between two 3-D points unobstructed?

Used by the visibility constraint (are two feature points joined by a clear
segment?) and by co-visibility learning (does a camera see a peak?). The
first point is the viewer: the second is lowered by earth curvature as that
viewer sees it (when the terrain has curvature on).
"""

from __future__ import annotations

import numpy as np

from .terrain import Terrain


def line_of_sight(terrain: Terrain, a, b, *, lift_m: float = 1.0, end_margin_m: float | None = None) -> np.ndarray:
    """Batched visibility between point pairs.

    Parameters
    ----------
    terrain : the Terrain scene.
    a, b : (N, 3) world points (metres); ``a`` is the viewer.
    lift_m : both ends are raised by this much, so points lying on the surface
        (peaks, a camera's foot) do not hit their own triangles.
    end_margin_m : the last stretch before ``b`` that is not tested (terrain
        grazing the target itself); default one cell size.

    Returns
    -------
    bool (N,): True where nothing blocks the segment.
    """
    a = np.atleast_2d(np.asarray(a, dtype=np.float64)).copy()
    b = np.atleast_2d(np.asarray(b, dtype=np.float64)).copy()
    a, b = np.broadcast_arrays(a, b)
    a, b = a.copy(), b.copy()
    a[:, 2] += lift_m
    b[:, 2] += lift_m
    b[:, 2] -= terrain.c * np.sum((b[:, :2] - a[:, :2]) ** 2, axis=1)  # as the viewer at a sees b
    margin = min(terrain.dem.cell_size) if end_margin_m is None else end_margin_m
    d = b - a
    length = np.linalg.norm(d, axis=1)
    clear = np.ones(len(a), dtype=bool)
    test = length > margin
    if test.any():
        frac = (length[test] - margin) / length[test]  # maxt in units of d
        clear[test] = ~terrain.ray_test(a[test], d[test], maxt=frac, viewer_xy=a[test, :2])
    return clear
