"""Stage 1d — the Model Horizon Database (beyond the paper).

The far horizon (terrain beyond ``near_m``) is rendered all around camera
centres on a regular grid (:func:`~skyrender.render.horizon.render_horizons`).
Seen from anywhere within a grid step, it changes by a fraction of a degree,
while the near foreground changes completely — hence the near clip. The
localizer matches a photo's skyline against every stored horizon at every
azimuth (:mod:`skyrender.localizer.horizon_search`): a way to a pose that does
not need three skyline peaks to be model feature points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.fft

from ..render import Terrain
from ..render.horizon import render_horizons
from .covisibility import viewpoint_grid


@dataclass(frozen=True)
class HorizonParams:
    spacing: float = 250.0  # metres between grid centres (coarser when over max_centres)
    height: float = 2.0  # camera height above ground (m)
    near_m: float = 1000.0  # terrain nearer than this is left out (m)
    bin_deg: float = 1.0  # azimuth bins (deg): 0.5 ranked right poses no better after verification, at twice the time
    max_centres: int = 40_000  # bounds memory and build time on large DEMs


@dataclass(frozen=True)
class Horizons:
    """centres : (N, 3) camera centres (world m); elevation : (N, B) float32 far-horizon
    elevation angles (deg) at azimuths j * bin_deg clockwise from grid north."""

    centres: np.ndarray
    elevation: np.ndarray
    bin_deg: float

    def __len__(self) -> int:
        return len(self.centres)

    @cached_property
    def spectra(self) -> tuple[np.ndarray, np.ndarray]:
        """rfft over azimuth of the elevations and of their squares (complex64): the
        localizer correlates a photo's skyline with every horizon at once."""
        p = self.elevation.astype(np.float32)
        return scipy.fft.rfft(p, axis=1, workers=-1), scipy.fft.rfft(p * p, axis=1, workers=-1)


def grid_spacing(extent: tuple[float, float, float, float], params: HorizonParams) -> float:
    """The grid step (m): ``params.spacing``, coarser when the DEM would need more than
    ``max_centres`` centres, finer when it would hold fewer than 16."""
    xmin, xmax, ymin, ymax = extent
    area = (xmax - xmin) * (ymax - ymin)
    spacing = max(params.spacing, math.sqrt(area / params.max_centres))
    return min(spacing, math.sqrt(area / 16.0))


def build_horizons(terrain: Terrain, params: HorizonParams = HorizonParams(), grid_dem=None,
                   progress: bool = False) -> Horizons:
    """Far horizons around a grid of camera centres over ``grid_dem`` (default: ``terrain``'s DEM);
    ``progress``: a bar on stderr."""
    grid_dem = terrain.dem if grid_dem is None else grid_dem
    centres = viewpoint_grid(grid_dem, grid_spacing(grid_dem.extent, params), params.height)
    centres = centres[np.isfinite(centres[:, 2])]
    elevation = render_horizons(terrain, centres, params.bin_deg, params.near_m, progress=progress)
    # at the precision a saved model keeps (float16: 0.03 deg at 60 deg), so that a model
    # localizes the same freshly built as loaded from its cache
    return Horizons(centres, elevation.astype(np.float16).astype(np.float32), params.bin_deg)
