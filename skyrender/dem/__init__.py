"""Stage 0 — the DEM: reading, repairing and georeferencing elevation grids."""

from .grid import DEM, RepairReport
from .io import load_dem, utm_epsg
from .synthetic import fractal_terrain

__all__ = ["DEM", "RepairReport", "load_dem", "utm_epsg", "fractal_terrain"]
