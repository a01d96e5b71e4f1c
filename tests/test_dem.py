"""DEM loading, georeferencing, repair, and the ground surface (README, Conventions)."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from skyrender.dem import DEM, fractal_terrain, load_dem
from skyrender.errors import InputError

from .conftest import data_path


def test_geotiff_utm_loads_with_its_crs_size_and_range():
    dem = load_dem(data_path("dem", "srtm_bigtujunga30m_utm11.tif"))
    assert dem.crs == "EPSG:32611"
    assert dem.shape == (643, 1197)
    assert dem.cell_size == (30.0, 30.0)
    assert dem.elevation.min() == pytest.approx(315, abs=0.5)
    assert dem.elevation.max() == pytest.approx(2295, abs=0.5)
    assert dem.repair.voids_filled == 0 and dem.repair.spikes_repaired == 0


def test_esri_ascii_grid_takes_the_crs_given():
    dem = load_dem(data_path("dem", "tirol_stubai_10m.asc"), crs="EPSG:31254")
    assert dem.crs == "EPSG:31254"
    assert dem.shape == (360, 324)
    assert dem.cell_size == (10.0, 10.0)
    assert dem.elevation.min() == pytest.approx(1349, abs=1)
    assert dem.elevation.max() == pytest.approx(2716, abs=1)
    lon, lat = dem.to_lonlat(*dem.centre)
    assert 11.0 < lon < 11.5 and 46.9 < lat < 47.3  # Stubai Alps


def test_esri_ascii_grid_without_crs_uses_a_local_frame():
    dem = load_dem(data_path("dem", "tirol_stubai_10m.asc"))
    assert dem.crs is None
    with pytest.raises(InputError):
        dem.to_lonlat(*dem.centre)


def test_hgt_is_reprojected_to_the_utm_zone_of_its_centre():
    dem = load_dem(data_path("dem", "N43E006.hgt"))
    assert dem.crs == "EPSG:32632"  # centre 6.5 E lies in zone 32 (6-12 E)
    dx, dy = dem.cell_size
    assert dx == dy and 60 < dx < 95  # 3 arc-seconds is 68 m x 93 m at 43 N
    rows, cols = dem.shape
    # the whole degree tile (about 81 km x 111 km) is kept, less the skew at its edges
    assert 100_000 < rows * dy < 111_500 and 75_000 < cols * dx < 82_000
    # bilinear resampling may shave summits a little, never invent relief
    assert -13 <= dem.elevation.min() < 10
    assert 1880 < dem.elevation.max() <= 1923
    lon, lat = dem.to_lonlat(*dem.centre)
    assert lon == pytest.approx(6.5, abs=0.01) and lat == pytest.approx(43.5, abs=0.01)


def test_hgt_voids_are_filled_and_counted():
    dem = load_dem(data_path("dem", "N47E011.hgt"))
    assert dem.repair.voids_filled == 54278
    assert np.isfinite(dem.elevation).all()
    assert 470 < dem.elevation.min() and dem.elevation.max() < 3462


def test_southern_hemisphere_tile_uses_a_327zz_zone():
    dem = load_dem(data_path("dem", "S44E170.hgt"))
    assert dem.crs == "EPSG:32759"


def test_builtin_jacksboro_is_north_up_in_utm_16n():
    dem = load_dem("builtin:jacksboro")
    assert dem.crs == "EPSG:32616"
    lon, lat = dem.to_lonlat(*dem.centre)
    assert lon == pytest.approx(-84.2458, abs=0.01) and lat == pytest.approx(36.5896, abs=0.01)
    assert 236 <= dem.elevation.min() < 260 and 1040 < dem.elevation.max() <= 1076


def test_ground_is_the_sw_ne_split_triangle_mesh():
    # 2 x 2 cells; centres at x = 5, 15 and y = 15 (north row), 5 (south row)
    z = np.array([[10.0, 20.0], [0.0, 40.0]])  # NW, NE / SW, SE
    dem = DEM(z, Affine(10, 0, 0, 0, -10, 20), None, "tiny")
    assert dem.ground(5, 15) == 10 and dem.ground(15, 15) == 20
    assert dem.ground(5, 5) == 0 and dem.ground(15, 5) == 40
    # On the SW-NE diagonal: the mean of SW and NE.
    assert dem.ground(10, 10) == pytest.approx(10.0)
    # South-east triangle (SW, SE, NE): s = 0.75, t = 0.25 -> 0 + .75*40 + .25*(20-40)
    assert dem.ground(12.5, 7.5) == pytest.approx(25.0)
    # North-west triangle (SW, NE, NW): s = 0.25, t = 0.75 -> 0 + .75*10 + .25*(20-10)
    assert dem.ground(7.5, 12.5) == pytest.approx(10.0)
    # Outside the outer cell centres: undefined
    assert np.isnan(dem.ground(4.9, 10)) and np.isnan(dem.ground(10, 15.1))


def test_ground_matches_cell_values_at_centres(view_dem):
    dem = view_dem
    rng = np.random.default_rng(1)
    r = rng.integers(0, dem.shape[0], 200)
    c = rng.integers(0, dem.shape[1], 200)
    g = dem.ground(dem.x_centres[c], dem.y_centres[r])
    np.testing.assert_allclose(g, dem.elevation[r, c], atol=1e-6)


def test_a_32767_spike_is_repaired_and_reported(tmp_path):
    z = np.full((40, 40), 500.0) + np.add.outer(np.arange(40.0), np.arange(40.0))
    z[20, 21] = 32767
    z[10, 10] = 950  # 450 m above its neighbours at 30 m cells: a sensor spike
    path = tmp_path / "spiky.npy"
    np.save(path, z)
    dem = load_dem(path, cell_size=30.0)
    assert dem.repair.spikes_repaired == 2
    assert dem.elevation.max() < 600
    assert dem.elevation[20, 21] == pytest.approx(500 + 20 + 21, abs=2)


def test_real_summits_are_not_taken_for_spikes():
    dem = load_dem(data_path("dem", "N27E086.hgt"))
    assert dem.elevation.max() > 8750  # Everest survives (bilinear shaves a few metres)
    assert dem.repair.spikes_repaired <= 2  # two deep gorge cells at most, no summit


@pytest.mark.parametrize("content", [b"hello, I am not a DEM\n", b""])
def test_a_text_file_is_not_a_dem(tmp_path, content):
    path = tmp_path / "dem.tif"
    path.write_bytes(content)
    with pytest.raises(InputError, match="not a DEM"):
        load_dem(path)


def test_npy_needs_a_cell_size(tmp_path):
    path = tmp_path / "a.npy"
    np.save(path, np.zeros((5, 5)))
    with pytest.raises(InputError, match="cell size"):
        load_dem(path)


def test_one_cell_dem_is_refused(tmp_path):
    path = tmp_path / "a.npy"
    np.save(path, np.zeros((1, 1)))
    with pytest.raises(InputError, match="2 x 2"):
        load_dem(path, cell_size=10)


def test_fractal_terrain_is_deterministic_and_paper_like():
    a = fractal_terrain(seed=3)
    b = fractal_terrain(seed=3)
    c = fractal_terrain(seed=4)
    assert a.shape == (600, 600) and a.cell_size == (50.0, 50.0)
    np.testing.assert_array_equal(a.elevation, b.elevation)
    assert not np.array_equal(a.elevation, c.elevation)
    relief = a.elevation.max() - np.median(a.elevation)
    assert relief > 800  # dominant mountains stand well above the plain


def test_lonlat_round_trip(view_dem):
    x, y = view_dem.centre
    lon, lat = view_dem.to_lonlat(x, y)
    x2, y2 = view_dem.from_lonlat(lon, lat)
    assert abs(x2 - x) < 1e-3 and abs(y2 - y) < 1e-3
