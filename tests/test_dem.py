"""DEM loading, georeferencing, repair, and the ground surface (README, Conventions)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from affine import Affine

from skyrender.dem import DEM, fractal_terrain, load_dem
from skyrender.errors import InputError

from .conftest import data_path


def test_the_shared_real_dems_load_with_their_known_crs_size_range_and_repairs():
    """Facts of the real DEMs in ../shared/data (one test about those files: it skips as a
    whole without them; the format behaviours below run on synthetic files everywhere)."""
    dem = load_dem(data_path("dem", "srtm_bigtujunga30m_utm11.tif"))
    assert dem.crs == "EPSG:32611" and dem.shape == (643, 1197) and dem.cell_size == (30.0, 30.0)
    assert dem.elevation.min() == pytest.approx(315, abs=0.5) and dem.elevation.max() == pytest.approx(2295, abs=0.5)
    assert dem.repair.voids_filled == 0 and dem.repair.spikes_repaired == 0

    dem = load_dem(data_path("dem", "tirol_stubai_10m.asc"), crs="EPSG:31254")
    assert dem.crs == "EPSG:31254" and dem.shape == (360, 324) and dem.cell_size == (10.0, 10.0)
    assert dem.elevation.min() == pytest.approx(1349, abs=1) and dem.elevation.max() == pytest.approx(2716, abs=1)
    lon, lat = dem.to_lonlat(*dem.centre)
    assert 11.0 < lon < 11.5 and 46.9 < lat < 47.3  # Stubai Alps

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

    dem = load_dem(data_path("dem", "N47E011.hgt"))
    assert dem.repair.voids_filled == 54278
    assert np.isfinite(dem.elevation).all()
    assert 470 < dem.elevation.min() and dem.elevation.max() < 3462

    assert load_dem(data_path("dem", "S44E170.hgt")).crs == "EPSG:32759"

    dem = load_dem(data_path("dem", "N27E086.hgt"))
    assert dem.elevation.max() > 8750  # Everest survives (bilinear shaves a few metres)
    assert dem.repair.spikes_repaired <= 2  # two deep gorge cells at most, no summit


def _write_hgt(path, void_rows=0):
    """A synthetic SRTM3 tile: a tilted plane (m) with ``void_rows`` rows of -32768 voids."""
    z = (500 + np.add.outer(np.arange(1201), np.arange(1201)) * 0.5).astype(">i2")
    z[600:600 + void_rows, 300:700] = -32768
    z.tofile(path)


def test_hgt_is_reprojected_to_the_utm_zone_of_its_centre_south_of_the_equator_too(tmp_path):
    _write_hgt(tmp_path / "N43E006.hgt")
    _write_hgt(tmp_path / "S44E170.hgt")
    north = load_dem(tmp_path / "N43E006.hgt")
    assert north.crs == "EPSG:32632"  # centre 6.5 E lies in zone 32 (6-12 E)
    dx, dy = north.cell_size
    assert dx == dy and 60 < dx < 95
    lon, lat = north.to_lonlat(*north.centre)
    assert lon == pytest.approx(6.5, abs=0.01) and lat == pytest.approx(43.5, abs=0.01)
    assert load_dem(tmp_path / "S44E170.hgt").crs == "EPSG:32759"  # south: 327zz


def test_hgt_voids_are_filled_and_counted(tmp_path):
    _write_hgt(tmp_path / "N47E011.hgt", void_rows=3)
    dem = load_dem(tmp_path / "N47E011.hgt")
    assert dem.repair.voids_filled == 3 * 400
    assert np.isfinite(dem.elevation).all()
    assert 490 < dem.elevation.min() and dem.elevation.max() < 500 + 1200 + 10


def _write_asc(path, z, cell=10.0):
    rows, cols = z.shape
    head = f"ncols {cols}\nnrows {rows}\nxllcorner 80000\nyllcorner 210000\ncellsize {cell}\nNODATA_value -9999\n"
    path.write_text(head + "\n".join(" ".join(f"{v:.1f}" for v in row) for row in z))


def test_esri_ascii_grid_takes_the_crs_given_or_uses_a_local_frame(tmp_path):
    z = 1400 + np.add.outer(np.arange(36.0), np.arange(32.0)) * 10
    _write_asc(tmp_path / "g.asc", z)
    dem = load_dem(tmp_path / "g.asc", crs="EPSG:31254")
    assert dem.crs == "EPSG:31254" and dem.shape == (36, 32) and dem.cell_size == (10.0, 10.0)
    assert dem.elevation.min() == pytest.approx(1400) and dem.elevation.max() == pytest.approx(1400 + 660)
    lon, lat = dem.to_lonlat(*dem.centre)
    assert 10.0 < lon < 12.5 and 46.0 < lat < 48.5  # MGI / Austria GK West
    local = load_dem(tmp_path / "g.asc")
    assert local.crs is None
    with pytest.raises(InputError):
        local.to_lonlat(*local.centre)


def test_geotiff_utm_loads_with_its_crs_size_and_range(tmp_path):
    import rasterio

    z = (315 + np.add.outer(np.arange(64), np.arange(120)) * 10).astype(np.float32)
    with rasterio.open(tmp_path / "u.tif", "w", driver="GTiff", height=64, width=120, count=1, dtype="float32",
                       crs="EPSG:32611", transform=Affine(30.0, 0, 380000.0, 0, -30.0, 3800000.0)) as ds:
        ds.write(z, 1)
    dem = load_dem(tmp_path / "u.tif")
    assert dem.crs == "EPSG:32611" and dem.shape == (64, 120) and dem.cell_size == (30.0, 30.0)
    assert dem.elevation.min() == pytest.approx(315) and dem.elevation.max() == pytest.approx(315 + 1820)
    assert dem.repair.voids_filled == 0 and dem.repair.spikes_repaired == 0


def test_builtin_jacksboro_is_north_up_in_utm_16n():
    dem = load_dem("builtin:jacksboro")
    assert dem.crs == "EPSG:32616"
    lon, lat = dem.to_lonlat(*dem.centre)
    assert lon == pytest.approx(-84.2458, abs=0.01) and lat == pytest.approx(36.5896, abs=0.01)
    assert 236 <= dem.elevation.min() < 260 and 1040 < dem.elevation.max() <= 1076
    # the highest cell is Cross Mountain (1,077 m, 36.4806 N 84.2369 W), near the south edge:
    # a north-south flip would put it 0.21 deg north, an east-west flip 0.03 deg west
    row, col = np.unravel_index(np.nanargmax(dem.elevation), dem.shape)
    x, y = dem.transform @ (col + 0.5, row + 0.5)
    lon, lat = dem.to_lonlat(x, y)
    assert lon == pytest.approx(-84.2369, abs=0.01) and lat == pytest.approx(36.4806, abs=0.01)


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


def test_slope_is_the_ground_plane_angle_and_nan_off_the_dem():
    """DEM.slope_deg on planes: 20 deg rising east, 35 deg falling south-west, level."""
    x, y = np.meshgrid(np.arange(30) * 30.0, np.arange(20)[::-1] * 30.0)  # cell centres, row 0 north
    transform = Affine(30, 0, -15, 0, -30, 19 * 30.0 + 15)
    for z, want in ((np.tan(np.radians(20)) * x, 20.0), (np.tan(np.radians(35)) * (x + y) / np.sqrt(2), 35.0),
                    (np.full(x.shape, 812.0), 0.0)):
        dem = DEM(z, transform, None, "plane")
        np.testing.assert_allclose(dem.slope_deg([100.0, 400.0, 731.5], [90.0, 300.0, 500.0]), want, atol=1e-9)
    assert np.isnan(dem.slope_deg(5.0, 300.0))  # one cell west of it lies off the DEM


def test_the_far_horizon_search_keeps_only_centres_on_ground_a_person_stands_on():
    from skyrender.localizer.horizon_search import standable_centres
    from skyrender.model import Horizons

    x, y = np.meshgrid(np.arange(40) * 30.0, np.arange(20)[::-1] * 30.0)
    z = np.where(x < 600, 100.0, 100.0 + np.tan(np.radians(40)) * (x - 600))  # level, then a 40 deg slope
    dem = DEM(z, Affine(30, 0, -15, 0, -30, 19 * 30.0 + 15), None, "step")
    xs = np.array([150.0, 450.0, 900.0, 1050.0])
    horizons = Horizons(np.c_[xs, np.full(4, 300.0), dem.ground(xs, 300.0)], np.zeros((4, 360), np.float32), 1.0)
    assert standable_centres(horizons, dem, np.inf) is None  # no bound: every centre
    assert standable_centres(horizons, dem, 30.0).tolist() == [0, 1]
    assert standable_centres(horizons, dem, 45.0).tolist() == [0, 1, 2, 3]


def test_a_centre_of_unknown_slope_is_kept_by_the_centre_bound_as_by_the_answer_bound():
    """On the DEM's outer cells the slope is unknown (NaN): neither too steep nor level. The far-horizon
    search's centre bound and the answer's bound both keep such a place (they once parted on it)."""
    from skyrender.localizer.horizon_search import standable_centres
    from skyrender.localizer.pipeline import standable_mask
    from skyrender.model import Horizons

    x, y = np.meshgrid(np.arange(40) * 30.0, np.arange(20)[::-1] * 30.0)
    z = 100.0 + np.tan(np.radians(40)) * x  # a 40 deg slope everywhere
    dem = DEM(z, Affine(30, 0, -15, 0, -30, 19 * 30.0 + 15), None, "slope")
    xs = np.array([0.0, 600.0])  # the westmost cell centre (no neighbour west of it), and one inside
    slopes = dem.slope_deg(xs, np.full(2, 300.0))
    assert np.isnan(slopes[0]) and slopes[1] > 39
    horizons = Horizons(np.c_[xs, np.full(2, 300.0), dem.ground(xs, 300.0)], np.zeros((2, 360), np.float32), 1.0)
    assert standable_centres(horizons, dem, 30.0).tolist() == [0]
    assert standable_mask(slopes, 30.0).tolist() == [True, False]


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


def test_spikes_are_the_cells_far_from_their_5x5_median():
    """find_spikes takes the median only where a cell stands far enough above its window's
    minimum (or below its maximum): the same cells as a full 5 x 5 median filter, on rough
    terrain with spikes and pits in the interior, on the edges and in a corner."""
    from scipy import ndimage

    from skyrender.dem.repair import find_spikes, spike_threshold_m

    rng = np.random.default_rng(5)
    z = ndimage.gaussian_filter(rng.normal(0.0, 400.0, (120, 90)), 2.0) * 3.0 + 2000.0
    cells = rng.integers(0, z.size, 300)
    z.flat[cells] += rng.choice([-900.0, -400.0, 250.0, 700.0], len(cells))
    z[0, :7] += 800.0
    z[-2:, -2:] -= 1200.0
    valid = np.ones(z.shape, bool)
    threshold = spike_threshold_m(30.0)
    residual = z - ndimage.median_filter(z, size=5, mode="nearest")
    expected = (residual > threshold) | (residual < -2.0 * threshold)
    assert 100 < expected.sum() < 300
    np.testing.assert_array_equal(find_spikes(z, 30.0, valid), expected)


def test_spikes_away_from_the_voids_are_refilled_as_a_fill_of_the_whole_grid_would():
    """repair_elevation fills the voids once and refills spikes that stand 3 or more cells from every void on a window of
    their own: the same values as filling the whole grid again without them (what it does when a spike is nearer)."""
    from scipy import ndimage

    from skyrender.dem.repair import _fill, repair_elevation

    rng = np.random.default_rng(2)
    z = ndimage.gaussian_filter(rng.normal(0.0, 300.0, (160, 140)), 3.0) * 4.0 + 1500.0
    z[40:110, 60:130] = np.nan  # a large void (a missing tile's corner)
    z[20, 30] += 900.0  # spikes far from it,
    z[130, 100] += 900.0
    z[140, 10] -= 1500.0  # a pit,
    z[75, 57] += 900.0  # and one two cells from its edge
    for spikes_near_void in (False, True):
        zz = z.copy()
        if not spikes_near_void:
            zz[75, 57] -= 900.0
        fixed, report, _ = repair_elevation(zz, 30.0)
        kept = np.isfinite(zz)
        kept[[20, 130, 140] + ([75] if spikes_near_void else []), [30, 100, 10] + ([57] if spikes_near_void else [])] = False
        assert report.spikes_repaired == 3 + spikes_near_void
        expected, _ = _fill(np.where(kept, zz, 0.0), kept)
        np.testing.assert_array_equal(fixed, expected)


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


def test_a_missing_tile_is_filled_with_a_smooth_surface_and_reported(tmp_path):
    """A void of a tile's size (a missing tile in a box of tiles): GDAL's fill, searching from every void cell,
    ran for over 10 minutes on 14 Alpine tiles; the cells far from data now take a surface filled on a coarse
    grid, GDAL filling only the band next to the data. The surface stays within the data's range and as smooth
    as the terrain around it, and the report counts the invented cells."""
    from skyrender.dem.repair import FAR_VOID_CELLS

    n, hole = 2400, slice(450, 1950)
    rows, cols = np.mgrid[0:n, 0:n]
    z = 1500.0 + 400.0 * np.sin(cols / 300.0) + 300.0 * np.cos(rows / 250.0)
    z[hole, hole] = np.nan
    np.save(tmp_path / "holey.npy", z)
    dem = load_dem(tmp_path / "holey.npy", cell_size=90.0)
    void = ~np.isfinite(z)
    assert dem.repair.voids_filled == 1500 * 1500
    inner = 1500 - 2 * FAR_VOID_CELLS
    assert inner**2 <= dem.repair.invented <= (inner + 2) ** 2
    assert "invented" in " ".join(dem.repair.notes)
    filled = dem.elevation[void]
    assert np.nanmin(z) - 1 <= filled.min() and filled.max() <= np.nanmax(z) + 1
    slope = np.hypot(*np.gradient(dem.elevation))
    assert slope[void].max() < 2.0 * np.nanmax(np.hypot(*np.gradient(np.where(void, np.nan, z))))


def test_small_voids_are_filled_by_gdal_as_before():
    """Voids whose fill is cheap go to GDAL's fill searching the whole grid, as before the coarse fill existed:
    the CH1 benchmark's DEM windows (up to 0.8 M void cells, where a window reaches into the missing N45E008
    tile) load to the same fingerprints."""
    from rasterio.fill import fillnodata

    from skyrender.dem.repair import _fill

    rng = np.random.default_rng(0)
    z = np.cumsum(rng.normal(0, 5, (300, 400)), axis=0) + 1000.0
    valid = np.ones(z.shape, bool)
    valid[100:140, 200:260] = False
    filled, invented = _fill(np.where(valid, z, 0.0), valid)
    plain = fillnodata(np.where(valid, z, 0.0).astype(np.float32), mask=valid.astype(np.uint8),
                       max_search_distance=400.0, smoothing_iterations=0).astype(np.float64)
    plain[valid] = z[valid]
    assert int(invented.sum()) == (40 - 2 * 8) * (60 - 2 * 8)  # marked all the same: cells over 8 from data
    np.testing.assert_array_equal(filled, plain)


def test_the_command_line_warns_when_a_dem_holds_invented_terrain(tmp_path, monkeypatch, capsys):
    from skyrender import cli
    from skyrender.dem import repair

    monkeypatch.setattr(repair, "GDAL_FILL_BUDGET", 1.0e4)  # a small grid, its large void filled as a missing tile's
    z = np.full((400, 400), 800.0) + np.arange(400.0)[None, :]
    z[50:350, 50:350] = np.nan
    np.save(tmp_path / "holey.npy", z)
    dem = cli._load_dem(str(tmp_path / "holey.npy"), None, 30.0)
    assert dem.repair.invented == (300 - 2 * 8) ** 2  # the void's cells over FAR_VOID_CELLS from its edge
    assert capsys.readouterr().err == ""  # held until the command ends without an error
    cli._print_warnings()
    err = capsys.readouterr().err
    assert "warning" in err and "invented" in err and "50 % of the DEM" in err
    small = np.full((200, 200), 800.0) + np.arange(200.0)[None, :]
    small[100:130, 100:130] = np.nan  # an ordinary void: 0.5 % of the DEM invented, no warning
    np.save(tmp_path / "small.npy", small)
    assert 0 < cli._load_dem(str(tmp_path / "small.npy"), None, 30.0).repair.invented
    cli._print_warnings()
    assert capsys.readouterr().err == ""


def test_the_command_line_warns_when_a_dem_is_too_large_for_the_far_horizon_grid(capsys):
    """The photo model's far horizons stand 500 m apart up to 60,000 centres (15,000 km^2); a box of 14 SRTM
    tiles (7,065 x 5,737 cells of 78 m) would put them 2 km apart: the user is told, and how large a DEM keeps
    500 m. A CH1 benchmark window (1.2 x 1.4 deg) is not warned about."""
    from types import SimpleNamespace

    from skyrender import cli
    from skyrender.model import ModelParams

    params = ModelParams.for_photos()
    for extent, warned in (((0.0, 5737 * 78.0, 0.0, 7065 * 78.0), True), ((0.0, 108_000.0, 0.0, 133_000.0), False)):
        model = SimpleNamespace(params=params, dem=SimpleNamespace(extent=extent))
        assert cli._warn_if_coarse(model) is model
        cli._print_warnings()
        err = capsys.readouterr().err
        assert ("2,027 m apart instead of 500 m" in err and "15,000 km^2" in err) if warned else err == ""


def test_a_command_prints_its_warning_when_it_succeeds_and_only_its_error_when_it_fails(tmp_path, capsys):
    """CONTRACT.md: bad input gives one line on stderr; the warning of invented terrain is held until the
    command ends without an error."""
    from skyrender import cli

    z = np.full((120, 120), 800.0) + np.arange(120.0)[None, :]
    z[20:100, 20:100] = np.nan
    np.save(tmp_path / "holey.npy", z)
    dem = str(tmp_path / "holey.npy")
    assert cli.main(["mesh", dem, "--out", str(tmp_path / "t.ply"), "--cell-size", "30", "--json"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("skyrender: warning: holey.npy: 28 % of the DEM")  # (80 - 16)^2 of 120^2
    assert cli.main(["mesh", dem, "--out", str(tmp_path / "t.xyz"), "--cell-size", "30"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("skyrender: error:")


def test_dem_bounds_cut_a_window_of_the_tiles_on_the_command_line(tmp_path, capsys):
    """``--dem-bounds W,S,E,N`` (the files' CRS): what the warning of a DEM too large for the far-horizon grid
    asks for. A quarter of a tile by a quarter reads 301 x 301 posts; bad or disjoint bounds are one-line errors."""
    from skyrender import cli

    tile = tmp_path / "N46E007.hgt"
    _write_hgt(tile)
    out = tmp_path / "t.ply"
    assert cli.main(["mesh", str(tile), "--dem-bounds", "7.25,46.25,7.5,46.5", "--out", str(out), "--json"]) == 0
    window = load_dem(tile, bounds=(7.25, 46.25, 7.5, 46.5))
    assert json.loads(capsys.readouterr().out)["vertices"] == window.elevation.size
    whole = load_dem(tile)
    assert 0.04 < window.elevation.size / whole.elevation.size < 0.09
    lon, lat = window.to_lonlat(*window.centre)
    assert lon == pytest.approx(7.375, abs=0.01) and lat == pytest.approx(46.375, abs=0.01)
    for bounds, says in (("7.5,46.25,7.25,46.5", "W < E"), ("a,b,c,d", "W,S,E,N"),
                         ("20,20,21,21", "outside the tiles")):
        assert cli.main(["mesh", str(tile), "--dem-bounds", bounds, "--out", str(out)]) == 2
        err = capsys.readouterr().err.splitlines()
        assert len(err) == 1 and says in err[0]
    assert cli.main(["mesh", "builtin:jacksboro", "--dem-bounds", "1,2,3,4", "--out", str(out)]) == 2
    assert "raster DEM files" in capsys.readouterr().err


def test_the_invented_mask_follows_the_grid_through_reprojection_and_block_means(tmp_path):
    """A tile with a 100 x 400-post void (rows 600-699, columns 300-699): after reprojection to UTM the
    invented cells lie where the void was, and a block-mean copy keeps them."""
    tile = tmp_path / "N46E007.hgt"
    _write_hgt(tile, void_rows=100)
    dem = load_dem(tile)
    assert dem.invented is not None and dem.invented.shape == dem.shape
    assert dem.repair.invented > 0
    middle = dem.from_lonlat(7 + 500 / 1200, 47 - 650 / 1200)
    away = dem.from_lonlat(7 + 500 / 1200, 47 - 200 / 1200)
    assert dem.is_invented(*middle) and not dem.is_invented(*away)
    assert abs(int(dem.invented.sum()) - dem.repair.invented) < 0.1 * dem.repair.invented  # resampled, about as many
    coarse = dem.coarsened(3)
    assert coarse.is_invented(*middle) and not coarse.is_invented(*away)
    assert load_dem(tmp_path / "N46E007.hgt", bounds=(7.0, 46.0, 7.2, 46.2)).invented is None  # no void in the window
