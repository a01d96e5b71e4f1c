"""The renderer: DEM terrain as a Mitsuba scene, skylines, photographs, line of sight."""

from .skyline import render_skylines
from .terrain import Terrain

__all__ = ["Terrain", "render_skylines"]
