"""Shared fixtures: the real data in ../shared/data (tests about one of its files skip
without it), the built-in DEM's terrains, built once, for everything else, and the localizer's
synthetic scene with its views (``test_localizer.py``, ``test_localizer_photos.py``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from skyrender.camera import Intrinsics

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
    dem = view_dem
    z = dem.elevation
    rows, cols = z.shape
    sub = z[rows // 3 : 2 * rows // 3, cols // 3 : 2 * cols // 3]
    r, c = np.unravel_index(np.argmin(sub), sub.shape)
    x, y = dem.x_centres[c + cols // 3], dem.y_centres[r + rows // 3]
    pose = dem.camera_pose(float(x), float(y), 2.0, 40.0, 4.0, 0.0)
    return pose, Intrinsics.from_fov(60.0, 320, 240)


# --- the localizer's synthetic scene and its rendered photographs --------------------------------
#: the views' intrinsics: 60 deg wide, 640 x 480
K = Intrinsics.from_fov(60.0, 640, 480)

# End-to-end thresholds on rendered photographs: what the code reaches on these views with a margin (2026-12-01:
# 0.2-22 m and 0.04-0.12 deg over the eight end-to-end localizations); the figures on a larger set are in the
# README (make bench-localize).
POS_TOL_M, ANG_TOL_DEG = 35.0, 0.2


@pytest.fixture(scope="session")
def scene():
    """The synthetic 600 x 600 @ 50 m scene of the issue, its terrain and model."""
    from skyrender.dem.synthetic import fractal_terrain
    from skyrender.model import build_model
    from skyrender.render import Terrain

    dem = fractal_terrain()
    terrain = Terrain(dem)
    return dem, terrain, build_model(dem, terrain=terrain)


@pytest.fixture(scope="session")
def views(scene):
    """Mountain views of the scene that satisfy the method's precondition (seeded)."""
    from skyrender.benchmarks.views import sample_views

    _, terrain, model = scene
    return sample_views(terrain, model, K, 5, seed=1)


def photo_of(terrain, pose, intr=K, **look) -> np.ndarray:
    """The rendered photograph (H, W, 3) uint8 of ``terrain`` from ``pose``, with a :class:`Look`'s ``look``."""
    from skyrender.render.photo import Look, render_photo

    return render_photo(terrain, pose, intr, Look(**look)).image


def assert_localized_near(result, truth) -> None:
    """``result`` answered, within :data:`POS_TOL_M` and :data:`ANG_TOL_DEG` of the ``truth`` pose, at least as
    confident as the render preset's threshold."""
    from skyrender.localizer import LocalizeParams

    assert result.localized, f"abstained after {result.hypotheses} hypotheses"
    t = truth.array()
    assert np.hypot(*(result.pose[:2] - t[:2])) < POS_TOL_M
    assert np.abs((result.pose[3:] - t[3:] + 180) % 360 - 180).max() < ANG_TOL_DEG
    assert result.confidence >= LocalizeParams().min_confidence
