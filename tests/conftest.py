"""Shared fixtures: the real data in ../shared/data, and terrains built once."""

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
def tujunga_dem():
    from skyrender.dem import load_dem

    return load_dem(data_path("dem", "srtm_bigtujunga30m_utm11.tif"))


@pytest.fixture(scope="session")
def tujunga_terrain(tujunga_dem):
    from skyrender.render import Terrain

    return Terrain(tujunga_dem)


@pytest.fixture(scope="session")
def tujunga_terrain_flat(tujunga_dem):
    from skyrender.render import Terrain

    return Terrain(tujunga_dem, curvature=False)


@pytest.fixture(scope="session")
def tujunga_view(tujunga_dem):
    """A camera in the Big Tujunga valley looking at the ridges, and 320x240 intrinsics."""
    from skyrender.camera import Intrinsics

    dem = tujunga_dem
    z = dem.elevation
    # lowest point of the central third: a valley floor with ridges around it
    rows, cols = z.shape
    sub = z[rows // 3 : 2 * rows // 3, cols // 3 : 2 * cols // 3]
    r, c = np.unravel_index(np.argmin(sub), sub.shape)
    x, y = dem.x_centres[c + cols // 3], dem.y_centres[r + rows // 3]
    pose = dem.camera_pose(float(x), float(y), 2.0, 40.0, 4.0, 0.0)
    return pose, Intrinsics.from_fov(60.0, 320, 240)
