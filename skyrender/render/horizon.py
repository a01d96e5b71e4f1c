"""Panoramic horizons: the elevation angle of the skyline all around a camera centre.

Eight level cameras (pan 0, 45, ..., 315 deg, 45 deg wide) render their skylines
(:func:`~skyrender.render.skyline.render_skylines`, optionally with a near clip);
each column's boundary becomes an (azimuth, elevation) direction, resampled onto
azimuth bins 0, bin, 2 bin, ... deg clockwise from grid north. Elevation angles
are apparent ones (earth curvature and refraction as the Terrain applies them),
so they compare directly with a photo's skyline turned into directions.
"""

from __future__ import annotations

import numpy as np

from ..camera import Intrinsics
from .skyline import render_skylines
from .terrain import Terrain

#: Level cameras per panorama and their columns (0.47 deg each at 45 deg wide).
PANORAMA_CAMERAS = 8
COLUMNS_PER_CAMERA = 96
#: Rows: +-45 deg at the centre column; a horizon beyond that is clipped there.
ROWS = 192


def render_horizons(terrain: Terrain, centres: np.ndarray, bin_deg: float = 0.5, near_m: float = 0.0,
                    tol_px: float = 0.25) -> np.ndarray:
    """(N, round(360 / bin_deg)) float32 horizon elevation angles (deg) around camera
    centres (N, 3) (world metres), ignoring terrain nearer than ``near_m`` (m).

    Bin j holds azimuth j * bin_deg (deg clockwise from grid north). A column that
    sees only sky gets the lowest elevation rendered (-45 deg at the centre column)."""
    centres = np.atleast_2d(np.asarray(centres, np.float64))
    n_bins = int(round(360.0 / bin_deg))
    if len(centres) == 0:
        return np.zeros((0, n_bins), np.float32)
    k = Intrinsics.from_fov(360.0 / PANORAMA_CAMERAS, COLUMNS_PER_CAMERA, ROWS)
    pans = np.arange(PANORAMA_CAMERAS) * 360.0 / PANORAMA_CAMERAS
    poses = np.zeros((len(centres) * PANORAMA_CAMERAS, 6))
    poses[:, :3] = np.repeat(centres, PANORAMA_CAMERAS, axis=0)
    poses[:, 3] = np.tile(pans, len(centres))
    v = render_skylines(terrain, poses, k, tol=tol_px, near_m=near_m)
    off = np.arange(COLUMNS_PER_CAMERA) + 0.5 - k.cx
    v = np.where(np.isnan(v), float(ROWS), v)
    elevation = np.degrees(np.arctan2(k.cy - v, np.hypot(k.f_px, off)))
    azimuth = (pans[:, None] + np.degrees(np.arctan(off / k.f_px))).ravel()  # the same for every centre
    order = np.argsort(azimuth % 360.0)
    azimuth = azimuth[order] % 360.0
    elevation = elevation.reshape(len(centres), -1)[:, order]
    # linear interpolation onto the bins, periodic in azimuth, for every centre at once
    grid = np.arange(n_bins) * bin_deg
    ext_az = np.r_[azimuth[-1] - 360.0, azimuth, azimuth[0] + 360.0]
    j = np.clip(np.searchsorted(ext_az, grid, side="right") - 1, 0, len(ext_az) - 2)
    w = (grid - ext_az[j]) / (ext_az[j + 1] - ext_az[j])
    ext_el = np.concatenate([elevation[:, -1:], elevation, elevation[:, :1]], axis=1)
    return ((1.0 - w) * ext_el[:, j] + w * ext_el[:, j + 1]).astype(np.float32)
