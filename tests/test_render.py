"""The Mitsuba renderer against independent computations."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from skyrender.camera import Intrinsics, Pose, camera_axes, mitsuba_to_world, pixel_directions, project
from skyrender.dem import DEM, load_dem
from skyrender.render import Terrain, render_skylines
from skyrender.render.photo import Look, cast_pixel_rays, render_photo
from skyrender.render.visibility import line_of_sight


def first_hit_rows(t: np.ndarray) -> np.ndarray:
    """Skyline of a one-sample-per-pixel full render: the first terrain row per column."""
    hit = np.isfinite(t)
    rows = np.argmax(hit, axis=0).astype(float)
    rows[~hit.any(axis=0)] = np.nan
    return rows


@pytest.mark.parametrize("curved", [True, False])
def test_ray_hits_project_back_to_their_pixels(curved, view_terrain, view_terrain_flat, valley_view):
    terrain = view_terrain if curved else view_terrain_flat
    pose, K = valley_view
    t, points, _, _ = cast_pixel_rays(terrain, pose, K, supersample=1)
    hit = np.isfinite(t)
    assert 0.2 < hit.mean() < 0.95  # both terrain and sky in view
    v, u = np.nonzero(hit)
    uv, ok = project(points[hit], pose, K, curvature=curved)
    assert ok.all()
    err = np.hypot(uv[:, 0] - (u + 0.5), uv[:, 1] - (v + 0.5))
    assert err.max() < 0.01
    # and the hit points lie on the terrain surface g(x, y) (float32 mesh: millimetres)
    g = terrain.dem.ground(points[hit, 0], points[hit, 1])
    assert np.nanmax(np.abs(points[hit, 2] - g)) < 0.05


def test_integer_skyline_equals_the_full_render(view_terrain, valley_view):
    pose, K = valley_view
    t, _, _, _ = cast_pixel_rays(view_terrain, pose, K, supersample=1)
    full = first_hit_rows(t)
    bisected = render_skylines(view_terrain, pose, K, subpixel=False)
    np.testing.assert_array_equal(bisected, full)


def test_subpixel_skyline_brackets_the_boundary_within_tolerance(view_terrain, valley_view):
    pose, K = valley_view
    sky = render_skylines(view_terrain, pose, K, subpixel=True, tol=0.02)
    inner = np.isfinite(sky) & (sky > 0.1) & (sky < K.height - 0.1)
    assert inner.mean() > 0.9
    u = np.arange(K.width)[inner] + 0.5
    origin = np.broadcast_to(pose.array()[:3], (inner.sum(), 3))
    above = view_terrain.ray_test(origin, pixel_directions(u, sky[inner] - 0.05, pose, K))
    below = view_terrain.ray_test(origin, pixel_directions(u, sky[inner] + 0.05, pose, K))
    assert not above.any() and below.all()
    integer = render_skylines(view_terrain, pose, K, subpixel=False)
    assert np.nanmax(np.abs(sky - integer)) <= 1.0


@pytest.mark.parametrize("subpixel", [True, False])
def test_skyline_distances_equal_an_independent_ray_cast(subpixel, view_terrain, valley_view):
    """The distance returned with the skyline is the first hit of a ray just below the
    boundary, cast again here with Terrain.intersect; the skyline itself is unchanged."""
    pose, K = valley_view
    sky, distance = render_skylines(view_terrain, pose, K, subpixel=subpixel, with_distance=True)
    np.testing.assert_array_equal(sky, render_skylines(view_terrain, pose, K, subpixel=subpixel))
    seen = np.isfinite(sky)
    assert seen.mean() > 0.9 and np.isinf(distance[~seen]).all()
    u = np.arange(K.width)[seen] + 0.5
    v = sky[seen] + (0.5 if not subpixel else 0.03)
    origin = np.broadcast_to(pose.array()[:3], (seen.sum(), 3))
    t, _, _ = view_terrain.intersect(origin, pixel_directions(u, v, pose, K))
    # a ray grazing the ridge can hit it or the slope behind: compare where the two agree to 1 %
    close = np.abs(t - distance[seen]) <= 0.01 * t
    assert close.mean() > 0.9
    assert np.all((distance[seen] > 0) & np.isfinite(distance[seen]))


def test_frozen_skylines_equal_unfrozen_ones_whatever_the_order_of_calls(monkeypatch, view_terrain, view_terrain_flat):
    """The skyline kernel is frozen (recorded once, replayed after). Calls of several shapes,
    with and without the near clip, on two terrains, mixed in a random order, give what the
    same kernel gives unfrozen. (One frozen function for all shapes replayed a wrong recording
    now and then: 2-4 of 30 such calls came out up to 50 deg off.)"""
    import drjit

    import skyrender.render.skyline as skyline

    dem = view_terrain.dem
    rng = np.random.default_rng(0)
    calls = []
    for _ in range(24):
        P = int(rng.integers(1, 30))
        xy = rng.uniform(-8000, 8000, (P, 2)) + dem.centre
        poses = np.zeros((P, 6))
        poses[:, :2] = xy
        poses[:, 2] = dem.ground(xy[:, 0], xy[:, 1]) + 2.0
        poses[:, 3], poses[:, 4] = rng.uniform(0, 360, P), rng.uniform(-5, 10, P)
        K = Intrinsics.from_fov(40.0, int(rng.choice([31, 64])), 120)
        calls.append((view_terrain if rng.random() < 0.5 else view_terrain_flat, poses, K, float(rng.choice([0, 300, 1000]))))
    frozen = [render_skylines(t, p, K, tol=0.1, near_m=n) for t, p, K, n in calls]
    monkeypatch.setattr(drjit, "freeze", lambda f, **kwargs: f)
    monkeypatch.setattr(skyline, "_frozen_bisect", {})
    unfrozen = [render_skylines(t, p, K, tol=0.1, near_m=n) for t, p, K, n in calls]
    for a, b in zip(frozen, unfrozen):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("near_m", [0.0, 300.0])
def test_skylines_started_from_a_guess_or_between_their_neighbours_equal_the_whole_column_bisection(
        monkeypatch, view_terrain, near_m):
    """``render_skylines(guess=...)`` starts each column's bisection at a guess (near, far, NaN, past the frame's
    edges) and, with no guess, bisects every COARSE_COLUMNS-th column first and starts the others between their
    neighbours: on level cameras, whose columns hit terrain below one boundary and miss above it, the same skylines
    and distances to the bit as bisecting every whole column; frames looking into the ground or the sky included."""
    import skyrender.render.skyline as skyline

    dem = view_terrain.dem
    rng = np.random.default_rng(3)
    P = 40
    xy = rng.uniform(-8000, 8000, (P, 2)) + dem.centre
    poses = np.zeros((P, 6))
    poses[:, :2] = xy
    poses[:, 2] = dem.ground(xy[:, 0], xy[:, 1]) + 2.0
    poses[:, 3] = rng.uniform(0, 360, P)
    poses[-4:, 4] = [-80.0, -80.0, 80.0, 80.0]  # terrain to the top of every column; sky to the bottom
    K = Intrinsics.from_fov(50.0, 96, 80)

    def render(**kwargs):
        return render_skylines(view_terrain, poses, K, tol=0.1, near_m=near_m, with_distance=True, **kwargs)

    whole = render()  # the default: every column bisected whole
    monkeypatch.setattr(skyline, "COARSE_COLUMNS", 4)
    two_pass = render()
    monkeypatch.setattr(skyline, "COARSE_COLUMNS", None)
    assert np.isnan(whole[0][-2:]).all() and (whole[0][-4:-2] == 0).all() and np.isfinite(whole[0][:-4]).mean() > 0.9
    guesses = [whole[0] + rng.normal(0, s, whole[0].shape) for s in (0.2, 3.0, 40.0)]
    guesses.append(np.where(rng.random(whole[0].shape) < 0.5, np.nan, -50.0))  # no guess, or one above the frame
    guesses.append(np.full(whole[0].shape, 500.0))  # below it
    for got in [two_pass] + [render(guess=g) for g in guesses]:
        np.testing.assert_array_equal(got[0], whole[0])
        np.testing.assert_array_equal(got[1], whole[1])


def test_batched_skylines_equal_one_by_one(view_terrain, valley_view):
    pose, K = valley_view
    poses = np.tile(pose.array(), (5, 1))
    poses[:, 3] += np.arange(5) * 7.0
    poses[:, 5] = [-10, -3, 0, 4, 10]
    batch = render_skylines(view_terrain, poses, K)
    for i in range(5):
        np.testing.assert_allclose(batch[i], render_skylines(view_terrain, Pose.from_array(poses[i]), K),
                                   atol=1e-4, equal_nan=True)


def test_positive_tilt_moves_the_skyline_down(view_terrain, valley_view):
    pose, K = valley_view
    s0 = render_skylines(view_terrain, pose, K)
    tilted = Pose(pose.x, pose.y, pose.z, pose.pan, pose.tilt + 3.0, pose.swing)
    s3 = render_skylines(view_terrain, tilted, K)
    assert np.nanmedian(s3 - s0) == pytest.approx(K.f_px * np.tan(np.radians(3)), rel=0.05)


def _single_mountain_dem():
    """Flat plain at 0 m with one Gaussian mountain at (5000, 9000): 200 x 200 cells of 50 m."""
    y, x = np.mgrid[0:200, 0:200]
    xc, yc = (x + 0.5) * 50, 10_000 - (y + 0.5) * 50
    z = 1500.0 * np.exp(-((xc - 5000) ** 2 + (yc - 9000) ** 2) / (2 * 400.0**2))
    return DEM(z, Affine(50, 0, 0, 0, -50, 10_000), None, "one-mountain")


def test_pan_zero_looks_north_at_the_mountain():
    dem = _single_mountain_dem()
    terrain = Terrain(dem, curvature=False)
    K = Intrinsics.from_fov(40, 200, 150)
    north = render_skylines(terrain, dem.camera_pose(5000, 2000, 2, 0, 0, 0), K)
    south = render_skylines(terrain, dem.camera_pose(5000, 2000, 2, 180, 0, 0), K)
    assert np.nanargmin(north) in (99, 100)  # the summit in the middle column
    assert np.nanmin(north) < 75 - 50  # well above the horizon row
    assert np.nanmin(south) > 74  # only flat plain behind: the horizon, no mountain


def test_positive_swing_turns_the_rendered_horizon_counter_clockwise():
    dem = _single_mountain_dem()
    terrain = Terrain(dem, curvature=False)
    K = Intrinsics.from_fov(40, 200, 150)
    sky = render_skylines(terrain, dem.camera_pose(5000, 500, 50, 180, 0, 8), K)  # flat plain horizon
    u = np.arange(200) + 0.5
    slope = np.polyfit(u[np.isfinite(sky)], sky[np.isfinite(sky)], 1)[0]
    assert slope < 0  # v falls to the right: counter-clockwise
    assert np.degrees(np.arctan(-slope)) == pytest.approx(8, abs=0.3)


def test_curvature_lowers_a_distant_ridge_by_the_formula():
    # A flat plain at 0 with an east-west wall 300 m high, 20 km north of the camera.
    rows, cols = 500, 100
    z = np.zeros((rows, cols))
    z[:40, :] = 300.0  # the northern 2 km: a plateau whose edge is the wall
    dem = DEM(z, Affine(50, 0, 0, 0, -50, rows * 50), None, "wall")
    edge_y = dem.y_centres[39]
    K = Intrinsics.from_fov(20, 101, 101)
    results = {}
    for curved in (True, False):
        terrain = Terrain(dem, curvature=curved)
        pose = dem.camera_pose(2500, edge_y - 20_000, 10, 0, 0, 0)
        sky = render_skylines(terrain, pose, K)
        expected, _ = project([[2500, edge_y, 300.0]], pose, K, curvature=curved)
        assert sky[50] == pytest.approx(expected[0, 1], abs=0.05)
        results[curved] = sky[50]
    drop_px = K.f_px * (20_000**2 * 0.87 / (2 * 6_371_000)) / 20_000
    assert results[True] - results[False] == pytest.approx(drop_px, abs=0.05)


def test_a_spike_in_the_dem_renders_no_phantom_ridge(tmp_path, view_dem, valley_view):
    pose, K = valley_view
    dem = view_dem
    # put a 32767 cell 3 km in front of the camera
    _, _, f = camera_axes(pose.pan, 0, 0)
    col, row = (int(v) for v in dem.fractional_index(pose.x + 3000 * f[0], pose.y + 3000 * f[1]))
    z = dem.elevation.copy()
    z[row, col] = 32767
    path = tmp_path / "spiked.npz"
    np.savez(path, elevation=z, cell_size=dem.cell_size[0], x_origin=dem.transform.c, y_origin=dem.transform.f,
             crs=dem.crs)
    spiked = load_dem(path)
    assert spiked.repair.spikes_repaired == 1
    clean_sky = render_skylines(Terrain(dem), pose, K)
    spiked_sky = render_skylines(Terrain(spiked), pose, K)
    assert np.nanmax(np.abs(clean_sky - spiked_sky)) < 1.0
    # without the repair the spike is a tower reaching the top of the image
    raw = DEM(z, dem.transform, dem.crs, "raw")
    raw_sky = render_skylines(Terrain(raw), pose, K)
    assert np.nanmin(raw_sky) < np.nanmin(clean_sky) - 20


def test_mitsuba_camera_frame_matches_the_contract_rays(view_terrain):
    mi = view_terrain.mi
    pose = Pose(10.0, 20.0, 30.0, 220.0, 6.0, -9.0)
    K = Intrinsics.from_fov(55, 320, 240)
    sensor = mi.load_dict({
        "type": "perspective", "fov": K.fov, "fov_axis": "x",
        "to_world": mi.ScalarTransform4f(mitsuba_to_world(pose).tolist()),
        "film": {"type": "hdrfilm", "width": K.width, "height": K.height},
    })
    rng = np.random.default_rng(5)
    u, v = rng.uniform(0, 320, 50), rng.uniform(0, 240, 50)
    film = mi.Point2f(mi.Float(u / K.width), mi.Float(v / K.height))
    ray, _ = sensor.sample_ray(mi.Float(0.0), mi.Float(0.5), film, mi.Point2f(0.5, 0.5))
    d_mi = np.stack([np.array(ray.d.x), np.array(ray.d.y), np.array(ray.d.z)], 1)
    np.testing.assert_allclose(d_mi, pixel_directions(u, v, pose, K), atol=1e-5)
    o_mi = np.stack([np.array(ray.o.x), np.array(ray.o.y), np.array(ray.o.z)], 1)
    # Mitsuba starts its rays on the near clip plane (0.01 m ahead): on the same line
    np.testing.assert_allclose(o_mi, pose.array()[:3] + 0.01 * d_mi / (d_mi @ camera_axes(220, 6, -9)[2])[:, None],
                               atol=1e-4)


def test_line_of_sight_agrees_with_sampling_the_ground(view_dem, view_terrain_flat):
    dem = view_dem
    rng = np.random.default_rng(7)
    xmin, xmax, ymin, ymax = dem.extent
    n = 300
    ax, bx = rng.uniform(xmin + 100, xmax - 100, (2, n))
    ay, by = rng.uniform(ymin + 100, ymax - 100, (2, n))
    a = np.column_stack([ax, ay, dem.ground(ax, ay) + rng.uniform(2, 300, n)])
    b = np.column_stack([bx, by, dem.ground(bx, by) + rng.uniform(2, 300, n)])
    clear = line_of_sight(view_terrain_flat, a, b, lift_m=0.0, end_margin_m=0.0)
    s = np.linspace(0, 1, 4000)[None, :, None]
    seg = a[:, None, :] + s * (b - a)[:, None, :]
    gap = seg[..., 2] - dem.ground(seg[..., 0], seg[..., 1])
    brute = np.nanmin(gap, axis=1) > 0
    clear_margin = np.abs(np.nanmin(gap, axis=1)) > 1.0  # leave out grazing segments
    assert 0.1 < brute.mean() < 0.9  # both outcomes occur
    np.testing.assert_array_equal(clear[clear_margin], brute[clear_margin])


def test_photo_is_deterministic_and_its_skyline_is_the_sky_boundary(view_terrain, valley_view):
    pose, K = valley_view
    look = Look(noise=0.02, occluders=0.2, seed=11)
    a = render_photo(view_terrain, pose, K, look)
    b = render_photo(view_terrain, pose, K, look)
    np.testing.assert_array_equal(a.image, b.image)
    assert a.image.shape == (K.height, K.width, 3) and a.image.dtype == np.uint8
    occluded = a.sky_boundary < a.skyline - 0.5
    assert 0.15 < occluded.mean() < 0.6
    # sky pixels are bright and bluish, terrain pixels darker
    rows = np.arange(K.height)[:, None]
    sky = rows < np.nan_to_num(a.sky_boundary, nan=K.height)[None, :] - 2
    ground = rows > np.nan_to_num(a.sky_boundary, nan=K.height)[None, :] + 2
    img = a.image.astype(float)
    assert img[sky].mean() > img[ground].mean() + 30
    assert (img[sky][:, 2] > img[sky][:, 0]).mean() > 0.95


def test_far_horizons_equal_a_march_over_the_dem(view_terrain):
    """Panoramic far horizons (near clip 1 km) against an independent computation: the
    largest apparent elevation angle of the DEM surface (earth curvature and refraction
    applied) sampled every 5 m along each azimuth from 1 km out. Without the clip the
    horizon can only be higher (near terrain adds to it)."""
    from skyrender.camera import earth_drop
    from skyrender.render.horizon import render_horizons

    dem = view_terrain.dem
    cx, cy = dem.centre
    centres = np.array([[x, y, float(dem.ground(x, y)) + 2.0] for x, y in ((cx, cy), (cx - 3000.0, cy + 2000.0))])
    far = render_horizons(view_terrain, centres, bin_deg=2.0, near_m=1000.0)
    full = render_horizons(view_terrain, centres, bin_deg=2.0)
    assert far.shape == (2, 180)
    assert (full >= far - 0.05).all()
    assert (full > far + 1.0).any()  # the near terrain matters somewhere
    az = np.radians(np.arange(180) * 2.0)
    d = np.arange(1000.0, 60_000.0, 5.0)
    for centre, rendered in zip(centres, far):
        x = centre[0] + d[None, :] * np.sin(az)[:, None]
        y = centre[1] + d[None, :] * np.cos(az)[:, None]
        angle = np.degrees(np.arctan2(dem.ground(x, y) - earth_drop(d, True) - centre[2], d))
        expected = np.nanmax(angle, axis=1)
        err = np.abs(rendered - expected)
        print(f"far horizon vs march: median {np.median(err):.3f} deg, 90th pct {np.percentile(err, 90):.3f}, "
              f"max {err.max():.3f}")
        # one bisected column per bin (0.125 px): median 0.023 / 0.032 deg, 90th pct 0.04 / 0.14 on these
        # two centres; eight 96-column cameras interpolated onto the bins (before 2026-12-04) 0.035 / 0.046, 0.07 / 0.13
        assert np.median(err) < 0.04 and np.percentile(err, 90) < 0.2


def test_the_ground_under_a_point_is_the_mesh_surface_an_upward_ray_meets(view_terrain):
    """``surface_z`` (the far horizons' "does a ray start under the ground") against rays cast
    straight up through the mesh from 2 cm below and 20 cm above its surface, and beside the
    DEM; within ``GROUND_MARGIN_M`` above it a point counts as under it."""
    from skyrender.render.terrain import GROUND_MARGIN_M, NumpyOps, surface_z

    rng = np.random.default_rng(3)
    x0, y0, dx, dy, cols, rows = view_terrain.grid
    n = 20_000
    cf, rf = rng.uniform(-0.1, 1.1, n) * cols, rng.uniform(-0.1, 1.1, n) * rows
    cf[:2000] = np.round(np.clip(cf[:2000], 1, cols - 2))  # on inner quad edges and vertices too
    x, y = x0 + cf * dx, y0 - rf * dy
    z = view_terrain.vertices[:, 2]
    height, over = surface_z(x, y, view_terrain.grid, z, NumpyOps)
    assert (over == ((cf >= 0) & (cf <= cols - 1) & (rf >= 0) & (rf <= rows - 1))).all()
    assert 0.6 < over.mean() < 0.8
    height = np.where(over, height, z.min())  # beside the DEM: at its lowest height
    for offset in (-0.02, 2.0 * GROUND_MARGIN_M):
        points = np.stack([x, y, height + offset], axis=1)
        upward = view_terrain.mesh_ray_test(points, np.tile([0.0, 0.0, 1.0], (n, 1)))
        assert (upward == (over & (offset < 0))).all()
        assert (view_terrain.mesh_under_ground(points) == upward).all()
    just_above = np.stack([x, y, height + 0.5 * GROUND_MARGIN_M], axis=1)
    assert (view_terrain.mesh_under_ground(just_above) == over).all()


def test_the_exported_mesh_loads_in_trimesh_and_its_mitsuba_xml_renders_the_same_terrain(tmp_path):
    """``skyrender mesh``: the PLY is the renderer's mesh (trimesh reads it back), and the
    Mitsuba scene XML written beside it, loaded as it is, gives the same ray hits as the
    renderer's in-memory terrain (flat earth, local coordinates)."""
    import trimesh

    from skyrender.backend import mitsuba
    from skyrender.cli import main
    from skyrender.dem.synthetic import fractal_terrain

    dem = fractal_terrain(48, 50.0, seed=3)
    np.savez(tmp_path / "dem.npz", elevation=dem.elevation, cell_size=50.0, x_origin=dem.transform.c,
             y_origin=dem.transform.f)
    assert main(["mesh", str(tmp_path / "dem.npz"), "--out", str(tmp_path / "t.ply")]) == 0
    loaded = load_dem(tmp_path / "dem.npz")
    mesh = trimesh.load(tmp_path / "t.ply", process=False)
    assert len(mesh.vertices) == 48 * 48 and len(mesh.faces) == 2 * 47 * 47
    terrain = Terrain(loaded, curvature=False)
    np.testing.assert_allclose(mesh.vertices, terrain.vertices, atol=1e-3)
    mi = mitsuba()
    scene = mi.load_file(str(tmp_path / "t.xml"))
    rng = np.random.default_rng(0)
    o = np.column_stack([rng.uniform(-900, 900, 64), rng.uniform(-900, 900, 64), np.full(64, 3000.0)])
    d = np.column_stack([rng.uniform(-0.3, 0.3, 64), rng.uniform(-0.3, 0.3, 64), -np.ones(64)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t_ours, _ = terrain.mesh_intersect(o, d)
    si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*o.T.astype(np.float32)), mi.Vector3f(*d.T.astype(np.float32))))
    t_xml = np.array(si.t, np.float64)
    hit = np.isfinite(t_ours)
    assert hit.mean() > 0.5
    np.testing.assert_allclose(t_xml[hit], t_ours[hit], atol=0.05)
    # the renderer's own mesh is that trimesh, and the XML scene renders the same skyline
    assert isinstance(terrain.mesh, trimesh.Trimesh)
    np.testing.assert_array_equal(np.asarray(terrain.mesh.vertices, np.float32), terrain.vertices)
    from_xml = Terrain(loaded, curvature=False)
    from_xml.scene = scene
    pose = loaded.camera_pose(float(loaded.x_centres[5]), float(loaded.y_centres[5]), 2.0, 135.0, 2.0, 0.0)
    K = Intrinsics.from_fov(60.0, 160, 120)
    sky, sky_xml = render_skylines(terrain, pose, K), render_skylines(from_xml, pose, K)
    assert np.isfinite(sky).mean() > 0.5
    np.testing.assert_allclose(sky_xml, sky, atol=0.05)
    # world coordinates and the other formats
    assert main(["mesh", str(tmp_path / "dem.npz"), "--out", str(tmp_path / "w.obj"), "--world"]) == 0
    world = trimesh.load(tmp_path / "w.obj", process=False)
    assert world.vertices[:, 0].min() == pytest.approx(loaded.x_centres.min(), abs=1e-3)
    assert main(["mesh", str(tmp_path / "dem.npz"), "--out", str(tmp_path / "t.glb")]) == 0
    assert main(["mesh", str(tmp_path / "dem.npz"), "--out", str(tmp_path / "t.stl")]) == 2
