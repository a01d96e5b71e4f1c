"""Shared fixtures: the real data in ../shared/data (tests about one of its files skip
without it), and the built-in DEM's terrains, built once, for everything else."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"


def data_path(*parts: str) -> Path:
    """A file under ../shared/data; skips the test (with the reason) where it is absent."""
    path = DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"real data not available here: {path} (the team's ../shared/data)")
    return path


@pytest.fixture(scope="session")
def view_dem():
    """The built-in real DEM (matplotlib's Jacksboro fault, 30 x 30 km): renderer and
    command-line tests run on it everywhere, with or without ../shared/data."""
    from skyrender.dem import load_dem

    return load_dem("builtin:jacksboro")


@pytest.fixture(scope="session")
def view_terrain(view_dem):
    from skyrender.render import Terrain

    return Terrain(view_dem)


@pytest.fixture(scope="session")
def view_terrain_flat(view_dem):
    from skyrender.render import Terrain

    return Terrain(view_dem, curvature=False)


@pytest.fixture(scope="session")
def valley_view(view_dem):
    """A camera on the lowest point of the DEM's central third looking at the ridges, and
    320x240 intrinsics."""
    from skyrender.camera import Intrinsics

    dem = view_dem
    z = dem.elevation
    rows, cols = z.shape
    sub = z[rows // 3 : 2 * rows // 3, cols // 3 : 2 * cols // 3]
    r, c = np.unravel_index(np.argmin(sub), sub.shape)
    x, y = dem.x_centres[c + cols // 3], dem.y_centres[r + rows // 3]
    pose = dem.camera_pose(float(x), float(y), 2.0, 40.0, 4.0, 0.0)
    return pose, Intrinsics.from_fov(60.0, 320, 240)
