"""Panoramic horizons: the elevation angle of the skyline all around a camera centre.

One level camera per azimuth bin, one column wide, looks exactly along the bin's
azimuth (pan j * bin deg); its column's boundary, bisected as every rendered skyline is
(:func:`~skyrender.render.skyline.skylines_of_rays`, optionally with a near clip),
becomes the bin's elevation. Every bin is a direct sample: nothing is rendered between
bins and nothing resampled. (Until 2026-12-02 eight 45-degree cameras of 96 columns
each, 2.1 x the rays, were interpolated onto the bins.) Elevation angles are apparent
ones (earth curvature and refraction as the Terrain applies them), so they compare
directly with a photo's skyline turned into directions.
"""

from __future__ import annotations

import math

import numpy as np

from ..camera import Intrinsics, pixel_ray_basis
from .skyline import skyline_iterations, skylines_of_rays
from .terrain import Terrain

#: Rows of each bin's one-column camera, and the elevation (deg) its top and bottom rows
#: reach; a horizon beyond that is clipped there.
ROWS = 192
MAX_ELEVATION_DEG = 40.0
#: Columns (centres x bins) per batch: bounds the ray arrays' memory (~100 MB).
COLUMNS_PER_BATCH = 1_000_000


def horizon_intrinsics() -> Intrinsics:
    """The one-column camera of every bin: ``ROWS`` rows spanning +-``MAX_ELEVATION_DEG``,
    the column's rays through its centre (u = 0.5)."""
    f_px = 0.5 * ROWS / math.tan(math.radians(MAX_ELEVATION_DEG))
    return Intrinsics(1, ROWS, f_px, 0.5, 0.5 * ROWS)


def render_horizons(terrain: Terrain, centres: np.ndarray, bin_deg: float = 0.5, near_m: float = 0.0,
                    tol_px: float = 0.125) -> np.ndarray:
    """(N, round(360 / bin_deg)) float32 horizon elevation angles (deg) around camera
    centres (N, 3) (world metres), ignoring terrain nearer than ``near_m`` (m).

    Bin j holds azimuth j * bin_deg (deg clockwise from grid north). Each elevation is
    bisected to ``tol_px`` rows of :func:`horizon_intrinsics` (0.125 px: 0.06 deg); a bin
    that sees only sky gets the lowest elevation rendered (-``MAX_ELEVATION_DEG``, within that)."""
    centres = np.atleast_2d(np.asarray(centres, np.float64))
    n_bins = int(round(360.0 / bin_deg))
    k = horizon_intrinsics()
    level = np.zeros((n_bins, 6))
    level[:, 3] = np.arange(n_bins) * bin_deg
    rays = pixel_ray_basis(level, k.array())  # the same for every centre, up to the mesh's shear
    n_iter = skyline_iterations(k.height, True, tol_px)
    out = np.empty((len(centres), n_bins), np.float32)
    per_batch = max(1, COLUMNS_PER_BATCH // n_bins)
    for start in range(0, len(centres), per_batch):
        batch = centres[start:start + per_batch]
        shape = (len(batch), n_bins, 3)
        origins, vectors = terrain.to_mesh_space(np.broadcast_to(batch[:, None, :], shape),
                                                 tuple(np.broadcast_to(r[None], shape) for r in rays))
        # no edge tests: a bin all sky bisects to the bottom row, one all terrain to the top
        v = skylines_of_rays(terrain, origins.reshape(-1, 3), *(r.reshape(-1, 3) for r in vectors), 1, k.height,
                             n_iter, near_m=near_m, edge_tests=False)[:, 0]
        out[start:start + per_batch] = np.degrees(np.arctan2(k.cy - v, k.f_px)).reshape(len(batch), n_bins)
    return out
