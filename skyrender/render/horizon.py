"""Panoramic horizons: the elevation angle of the skyline all around a camera centre.

Each azimuth bin (0, bin, 2 bin, ... deg clockwise from grid north) is one level camera of a
single column looking exactly along it (:func:`~skyrender.render.skyline.render_skylines`,
optionally with a near clip), so the bins are sampled where they lie, not resampled from
evenly spaced pixel columns. Elevation angles are apparent ones (earth curvature and
refraction as the Terrain applies them), so they compare directly with a photo's skyline
turned into directions.
"""

from __future__ import annotations

import math

import numpy as np

from ..camera import Intrinsics
from ..progress import progress as progress_bar
from .skyline import render_skylines
from .terrain import Terrain

#: Rows of each bin's one-column camera, and its focal length (px): +-39.6 deg of elevation
#: (what eight 45-degree cameras of 96 columns gave at a column's centre, before 2026-12-04).
ROWS = 192
F_PX = 48.0 / math.tan(math.radians(22.5))
#: Centres rendered per call (x bins poses each): bounds the per-pose ray bases in memory.
CENTRES_PER_CALL = 2048


def render_horizons(terrain: Terrain, centres: np.ndarray, bin_deg: float = 0.5, near_m: float = 0.0,
                    tol_px: float = 0.125, progress: bool = False) -> np.ndarray:
    """(N, round(360 / bin_deg)) float32 horizon elevation angles (deg) around camera
    centres (N, 3) (world metres), ignoring terrain nearer than ``near_m`` (m).

    Bin j holds azimuth j * bin_deg (deg clockwise from grid north). A bin that sees only
    sky gets the lowest elevation rendered (-39.6 deg). ``tol_px``: the bisection's
    tolerance in the one-column cameras' pixels (0.125 px = 0.06 deg). ``progress``: a bar on stderr.

    Why one column per bin: eight 45-degree cameras of 96 columns each (768 columns, bisected to
    0.25 px), linearly interpolated onto 360 one-degree bins, traced twice the rays of 360 columns
    bisected one step further, and were no closer to a march over the DEM (2026-12-04,
    ``experiments/scale/one-column-horizons/``)."""
    centres = np.atleast_2d(np.asarray(centres, np.float64))
    n_bins = int(round(360.0 / bin_deg))
    out = np.empty((len(centres), n_bins), np.float32)
    k = Intrinsics(1, ROWS, F_PX, 0.5, ROWS / 2.0)  # the column's centre u = 0.5 looks along the pan
    pans = np.arange(n_bins) * bin_deg
    for start in progress_bar(range(0, len(centres), CENTRES_PER_CALL), "far horizons", progress, unit="chunk",
                              leave=False):
        chunk = centres[start:start + CENTRES_PER_CALL]
        poses = np.zeros((len(chunk) * n_bins, 6))
        poses[:, :3] = np.repeat(chunk, n_bins, axis=0)
        poses[:, 3] = np.tile(pans, len(chunk))
        v = render_skylines(terrain, poses, k, tol=tol_px, near_m=near_m)[:, 0]
        v = np.where(np.isnan(v), float(ROWS), v)
        out[start:start + len(chunk)] = np.degrees(np.arctan2(k.cy - v, k.f_px)).reshape(len(chunk), n_bins)
    return out
