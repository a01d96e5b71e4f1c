"""Model side: peaks, neighbour sets, co-visibility, the model directory."""

from __future__ import annotations

import json

import numpy as np
import pytest
from affine import Affine
from scipy.optimize import minimize

from skyrender.cli import main
from skyrender.dem import DEM, fractal_terrain
from skyrender.errors import InputError
from skyrender.model import (
    CovisibilityParams,
    ModelParams,
    PeakParams,
    build_model,
    find_peaks,
    k_nearest_features,
    learn_covisibility,
    load_model,
    save_model,
)
from skyrender.model.covisibility import skyline_features, viewpoint_grid
from skyrender.model.neighbours import most_covisible_features
from skyrender.render import Terrain

CELL = 50.0
# (x, y, height, sigma): A and B share a massif 1.3 km apart; C stands alone 5 km away.
BUMPS = [(3020.3, 6510.7, 1000.0, 350.0), (4310.6, 6480.2, 700.0, 300.0), (6980.9, 3040.4, 800.0, 400.0),
         (7500.2, 7620.8, 400.0, 250.0)]


def gaussians(x, y):
    return 200.0 + sum(h * np.exp(-((x - bx) ** 2 + (y - by) ** 2) / (2 * s**2)) for bx, by, h, s in BUMPS)


def analytic_dem() -> DEM:
    y = 10_000 - (np.arange(200) + 0.5) * CELL
    x = (np.arange(200) + 0.5) * CELL
    return DEM(gaussians(x[None, :], y[:, None]), Affine(CELL, 0, 0, 0, -CELL, 10_000), None, "gaussians")


def true_summits():
    out = []
    for bx, by, _, _ in BUMPS:
        res = minimize(lambda p: -gaussians(p[0], p[1]), [bx, by], method="Nelder-Mead",
                       options={"xatol": 1e-4, "fatol": 1e-8, "maxiter": 4000})
        out.append(res.x)
    return np.array(out)


def test_peaks_of_an_analytic_terrain_lie_within_a_quarter_cell():
    peaks = find_peaks(analytic_dem(), PeakParams(major_radius=1800, minor_radius=650))
    truth = true_summits()
    assert len(peaks) == 4
    for tx, ty in truth:
        d = np.hypot(peaks.x - tx, peaks.y - ty)
        assert d.min() < CELL / 4
    # summit heights from the quadratic fit are close to the analytic maxima
    z_true = np.sort(gaussians(truth[:, 0], truth[:, 1]))[::-1]
    np.testing.assert_allclose(peaks.z, z_true, atol=3.0)


def test_major_and_minor_follow_the_radii():
    truth = true_summits()
    peaks = find_peaks(analytic_dem(), PeakParams(major_radius=1800, minor_radius=650))
    major = {int(np.argmin(np.hypot(truth[:, 0] - x, truth[:, 1] - y))) for x, y in
             zip(peaks.x[peaks.major], peaks.y[peaks.major])}
    assert major == {0, 2, 3}  # B is 1.3 km from the higher A: minor only
    wide = find_peaks(analytic_dem(), PeakParams(major_radius=5000, minor_radius=650))
    assert int(wide.major.sum()) == 2  # within 5 km only A and C stay highest


def test_radii_are_metres_not_cells():
    coarse = analytic_dem()
    fine_x = (np.arange(400) + 0.5) * 25.0
    fine_y = 10_000 - (np.arange(400) + 0.5) * 25.0
    fine = DEM(gaussians(fine_x[None, :], fine_y[:, None]), Affine(25, 0, 0, 0, -25, 10_000), None, "fine")
    a, b = find_peaks(coarse), find_peaks(fine)
    assert len(a) == len(b) and int(a.major.sum()) == int(b.major.sum())


def test_paper_like_dem_gives_tens_of_major_and_hundreds_of_features():
    peaks = find_peaks(fractal_terrain(seed=0))
    assert 15 <= int(peaks.major.sum()) <= 60
    assert 120 <= len(peaks) <= 320
    assert (peaks.prominence >= 0).all() and (np.diff(peaks.z) <= 0).all()


def test_neighbour_sets_match_brute_force():
    peaks = find_peaks(fractal_terrain(seed=1))
    piv = np.flatnonzero(peaks.major)
    nb = k_nearest_features(peaks.xyz[piv, :2], peaks.xyz[:, :2], peaks.id[piv], k=15)
    for i, p in enumerate(piv):
        d = np.hypot(peaks.x - peaks.x[p], peaks.y - peaks.y[p])
        d[p] = np.inf
        brute = np.argsort(d, kind="stable")[:15]
        np.testing.assert_allclose(np.sort(d[nb[i]]), np.sort(d[brute]))
        assert p not in nb[i]


def test_most_covisible_features_rank_by_count_then_distance():
    together = np.array([[9, 3, 5, 0, 5],
                         [3, 9, 0, 0, 1],
                         [5, 0, 9, 2, 5],
                         [0, 0, 2, 9, 0],
                         [5, 1, 5, 0, 9]])
    xy = np.array([[0.0, 0.0], [100.0, 0.0], [300.0, 0.0], [50.0, 0.0], [200.0, 0.0]])
    nb = most_covisible_features(together, xy, k=3)
    # row 0: counts 5 (points 2 and 4, the nearer 4 first), then 3; never-together 3 left out
    np.testing.assert_array_equal(nb, [[4, 2, 1], [0, 4, -1], [4, 0, 3], [2, -1, -1], [2, 0, 1]])


def brute_skyline_feature(dem: DEM, cam, feat, tol_deg: float, min_range: float, max_range: float):
    """Flat earth: visible by dense sampling of g along the segment, and no terrain
    beyond it along the azimuth rising above the feature's elevation angle + tol."""
    d = np.hypot(*(feat[:2] - cam[:2]))
    if not (min_range <= d <= max_range):
        return False, np.inf
    s = np.linspace(0, 1, 3000)[:-1]
    seg = cam[None, :] + s[:, None] * (feat - cam)[None, :]
    sample_d = s * d
    keep = sample_d < d - min(dem.cell_size)  # the last cell before the summit is not tested
    gap = (seg[keep, 2] - dem.ground(seg[keep, 0], seg[keep, 1]))
    visible = np.nanmin(gap) > 0
    elev = np.arctan2(feat[2] - cam[2], d)
    direction = (feat[:2] - cam[:2]) / d
    far = np.linspace(1.0, 80_000.0, 20_000)
    px, py = cam[0] + far * direction[0], cam[1] + far * direction[1]
    g = dem.ground(px, py)
    horizon = np.nanmax(np.arctan2(g - cam[2], far))
    los_margin = abs(np.nanmin(gap)) / d  # angular clearance (or depth) of the segment
    if not visible:
        return False, los_margin
    return bool(horizon <= elev + np.radians(tol_deg)), min(los_margin, abs(horizon - elev - np.radians(tol_deg)))


def test_covisibility_agrees_with_brute_force_line_of_sight_and_horizon():
    dem = fractal_terrain(200, 50.0, seed=2)
    peaks = find_peaks(dem)
    terrain = Terrain(dem, curvature=False)
    params = CovisibilityParams(spacing=2000.0, height=2.0)
    rng = np.random.default_rng(0)
    xmin, xmax, ymin, ymax = dem.extent
    cams_xy = rng.uniform([xmin + 500, ymin + 500], [xmax - 500, ymax - 500], (16, 2))
    cams = np.column_stack([cams_xy, dem.ground(cams_xy[:, 0], cams_xy[:, 1]) + 2.0])
    fast = skyline_features(terrain, cams, peaks.xyz, params)
    checked = agree = 0
    for v, cam in enumerate(cams):
        for f, feat in enumerate(peaks.xyz):
            truth, margin = brute_skyline_feature(dem, cam, feat, params.horizon_tol_deg, params.min_range,
                                                  params.max_range)
            if margin < 2e-4:  # grazing: sampling cannot decide
                continue
            checked += 1
            agree += truth == fast[v, f]
    assert checked > 300, checked
    print(f"co-visibility: {agree}/{checked} decisions agree")
    assert fast.any()
    assert agree / checked >= 0.99


def test_covisibility_counts_are_the_viewpoints_where_both_features_are_skyline_features():
    """``together[f, g]``: viewpoints where f and g both are skyline features, accumulated in
    chunks of viewpoints (here many) as a sparse product: the dense count, exactly."""
    dem = fractal_terrain(200, 50.0, seed=2)
    features = find_peaks(dem).xyz
    terrain = Terrain(dem)
    params = CovisibilityParams(spacing=600.0)
    learned = learn_covisibility(terrain, features, params, max_pairs=20 * len(features))
    cameras = viewpoint_grid(dem, params.spacing, params.height)
    sky = skyline_features(terrain, cameras, features, params).astype(np.int64)
    assert learned.n_viewpoints == len(cameras) > 200 and sky.sum() > 100
    assert learned.together.dtype == np.int64
    np.testing.assert_array_equal(learned.together, sky.T @ sky)


def test_pairs_in_range_are_every_pair_within_the_distances_in_row_major_order():
    from skyrender.model.covisibility import pairs_in_range

    rng = np.random.default_rng(4)
    cameras = rng.uniform(0.0, 5000.0, (60, 3))
    points = np.vstack([rng.uniform(0.0, 5000.0, (80, 3)), cameras[:3] + [[2000.0, 0.0, 0.0], [0.0, 200.0, 0.0],
                                                                          [1.0, 0.0, 0.0]]])  # on both bounds
    v, f, d = pairs_in_range(cameras, points, 200.0, 2000.0)
    all_d = np.hypot(points[None, :, 0] - cameras[:, None, 0], points[None, :, 1] - cameras[:, None, 1])
    expected = np.flatnonzero((all_d >= 200.0) & (all_d <= 2000.0))
    np.testing.assert_array_equal(v * len(points) + f, expected)
    np.testing.assert_array_equal(d, all_d.ravel()[expected])
    assert {(0, 80), (1, 81)} <= set(zip(v.tolist(), f.tolist())) and (2, 82) not in set(zip(v.tolist(), f.tolist()))


def test_probabilities_lie_in_unit_interval_and_the_model_round_trips(tmp_path):
    dem = fractal_terrain(300, 50.0, seed=5)
    model = build_model(dem, ModelParams(covisibility=CovisibilityParams(spacing=1500.0)))
    assert ((model.p_pivot >= 0) & (model.p_pivot <= 1)).all() and model.p_pivot.max() > 0
    assert ((model.p_neighbour >= 0) & (model.p_neighbour <= 1)).all() and model.p_neighbour.max() > 0
    save_model(model, tmp_path / "m")
    again = load_model(tmp_path / "m", dem=dem)
    np.testing.assert_array_equal(again.features.x, model.features.x)
    np.testing.assert_array_equal(again.neighbours, model.neighbours)
    np.testing.assert_array_equal(again.covisibility.together, model.covisibility.together)
    alone = load_model(tmp_path / "m")  # self-contained: carries its DEM
    assert alone.dem.fingerprint() == dem.fingerprint()


def test_a_model_is_refused_for_another_dem_or_a_stale_format(tmp_path):
    dem = fractal_terrain(200, 50.0, seed=6)
    model = build_model(dem, ModelParams(covisibility=CovisibilityParams(spacing=2000.0)))
    save_model(model, tmp_path / "m")
    with pytest.raises(InputError, match="built for DEM"):
        load_model(tmp_path / "m", dem=fractal_terrain(200, 50.0, seed=7))
    with pytest.raises(InputError, match="other parameters"):
        load_model(tmp_path / "m", params=ModelParams(k=10))
    meta = json.loads((tmp_path / "m" / "model.json").read_text())
    meta["format_version"] = 0
    (tmp_path / "m" / "model.json").write_text(json.dumps(meta))
    with pytest.raises(InputError, match="format version"):
        load_model(tmp_path / "m")


def test_prior_selects_features():
    dem = fractal_terrain(300, 50.0, seed=5)
    model = build_model(dem, ModelParams(covisibility=CovisibilityParams(spacing=3000.0)))
    piv = model.pivots
    first = int(model.features.id[piv[0]])
    np.testing.assert_array_equal(np.flatnonzero(model.features_for_prior(ids=[first])), [piv[0]])
    x, y = model.features.x[piv[0]], model.features.y[piv[0]]
    np.testing.assert_array_equal(np.flatnonzero(model.features_for_prior(x=x, y=y, radius=1.0)), [piv[0]])
    assert model.features_for_prior().all()
    with pytest.raises(InputError):
        model.features_for_prior(ids=[99999])
    with pytest.raises(InputError):
        model.features_for_prior(x=x, y=y, radius=-1.0)


def _cli(capsys, args):
    code = main(args)
    err = capsys.readouterr().err.strip().splitlines()
    return code, err


def test_cli_model_builds_and_prints_a_summary(tmp_path, capsys):
    dem_path = tmp_path / "dem.npz"
    dem = fractal_terrain(200, 50.0, seed=8)
    np.savez(dem_path, elevation=dem.elevation, cell_size=50.0, x_origin=dem.transform.c,
             y_origin=dem.transform.f, crs=dem.crs)
    code = main(["model", str(dem_path), "--out", str(tmp_path / "m"), "--json", "--spacing", "2000"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["features"] > 0 and out["major"] > 0 and out["rows"] == 200
    assert (tmp_path / "m" / "model.json").exists()


@pytest.mark.parametrize("case", ["flat", "one_cell", "unwritable", "out_is_file"])
def test_cli_model_bad_input_gives_one_line_and_exit_2(case, tmp_path, capsys):
    dem_path = tmp_path / "dem.npy"
    out = tmp_path / "m"
    if case == "flat":
        np.save(dem_path, np.full((100, 100), 500.0))
    elif case == "one_cell":
        np.save(dem_path, np.full((1, 1), 500.0))
    else:
        np.save(dem_path, fractal_terrain(100, 50.0, seed=1).elevation)
        if case == "unwritable":
            out = tmp_path / "ro" / "m"
            (tmp_path / "ro").mkdir()
            (tmp_path / "ro").chmod(0o500)
            out = "/proc/skyrender-model" if __import__("os").geteuid() == 0 else out
        else:
            out.write_text("a file")
    code, err = _cli(capsys, ["model", str(dem_path), "--cell-size", "50", "--out", str(out)])
    assert code == 2
    assert len(err) == 1 and err[0].startswith("skyrender: error:")


def test_a_fine_dem_renders_its_model_statistics_on_coarser_blocks():
    """Cells finer than ``render_cell_m`` / 1.5 (a 1-arc-second tile's 26 m: 2 x 2 blocks):
    the peaks are the fine DEM's own, the horizons' centres stand on it, and the far horizons
    from the coarser mesh are close to the full mesh's, a little lower (block means round off
    ridges). Measured on this rough 20 m fractal: p90 1.39 deg, mean signed -0.60 deg; on the
    real 1" Glarus DEM p90 0.18 deg, signed -0.12 deg (the 3" grid itself: p90 0.36 deg)."""
    assert [ModelParams().render_factor(c) for c in (77.0, 50.0, 30.0, 26.0, 10.0)] == [1, 1, 1, 2, 4]
    assert ModelParams(render_cell_m=0).render_factor(10.0) == 1
    dem = fractal_terrain(300, 20.0, seed=5)
    params = ModelParams(covisibility=CovisibilityParams(spacing=1500.0))
    coarse = build_model(dem, params)
    full = build_model(dem, ModelParams(covisibility=CovisibilityParams(spacing=1500.0), render_cell_m=0))
    np.testing.assert_array_equal(coarse.features.xyz, full.features.xyz)
    np.testing.assert_array_equal(coarse.horizons.centres, full.horizons.centres)  # on the DEM itself
    diff = coarse.horizons.elevation - full.horizons.elevation
    assert np.percentile(np.abs(diff), 90) < 2.0 and -1.0 < diff.mean() < -0.2


def test_cached_models_live_under_the_cache_generation_and_load_as_built(tmp_path, monkeypatch, capsys):
    """A model cached by code older than ``CACHE_GENERATION`` (a bare key directory) is not
    reused: the cache reads and writes ``g<generation>/<key>`` only. With ``progress`` the build
    (and only the build) says so on stderr."""
    from skyrender.model import CACHE_GENERATION, cached_model, model_cache_key

    monkeypatch.setenv("SKYRENDER_CACHE", str(tmp_path))
    dem = fractal_terrain(120, 50.0, seed=4)
    (tmp_path / model_cache_key(dem)).mkdir()  # an older generation's directory, empty: never read
    built = cached_model(dem, progress=True)
    where = tmp_path / f"g{CACHE_GENERATION}" / model_cache_key(dem)
    assert CACHE_GENERATION >= 2 and (where / "model.json").is_file()
    assert f"building the model of {dem.name} (120 x 120 cells; first use, cached in {where})" in capsys.readouterr().err
    again = cached_model(dem, progress=True)
    assert "building" not in capsys.readouterr().err
    np.testing.assert_array_equal(again.horizons.elevation, built.horizons.elevation)
    np.testing.assert_array_equal(again.features.xyz, built.features.xyz)
