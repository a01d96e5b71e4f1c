"""Camera conventions (README, Conventions), checked with plain geometry."""

from __future__ import annotations

import numpy as np
import pytest

from skyrender.camera import CURVATURE_COEFF, Intrinsics, Pose, camera_axes, earth_drop, pixel_directions, project


def test_axes_are_orthonormal_and_follow_the_contract():
    rng = np.random.default_rng(0)
    pan, tilt, swing = rng.uniform(0, 360, 50), rng.uniform(-80, 80, 50), rng.uniform(-180, 180, 50)
    r, u, f = camera_axes(pan, tilt, swing)
    for a in (r, u, f):
        np.testing.assert_allclose(np.linalg.norm(a, axis=1), 1, atol=1e-12)
    np.testing.assert_allclose(np.sum(r * u, 1), 0, atol=1e-12)
    np.testing.assert_allclose(np.sum(r * f, 1), 0, atol=1e-12)
    np.testing.assert_allclose(np.cross(r, f), u, atol=1e-12)  # u0 = r0 x f, kept by the roll


def test_pan_zero_looks_north_and_pan_90_east():
    _, _, f = camera_axes(0.0, 0.0, 0.0)
    np.testing.assert_allclose(f, [0, 1, 0], atol=1e-12)
    r, _, f = camera_axes(90.0, 0.0, 0.0)
    np.testing.assert_allclose(f, [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(r, [0, -1, 0], atol=1e-12)  # looking east, right is south


def test_point_ahead_projects_to_the_principal_point():
    K = Intrinsics.from_fov(60, 640, 480)
    pose = Pose(100.0, 200.0, 50.0, 30.0, 10.0, 5.0)
    _, _, f = camera_axes(30.0, 10.0, 5.0)
    uv, ok = project(np.array([100.0, 200.0, 50.0]) + 1000 * f, pose, K, curvature=False)
    assert ok[0]
    np.testing.assert_allclose(uv[0], [320, 240], atol=1e-9)


def test_fov_matches_the_image_edges():
    K = Intrinsics.from_fov(60, 640, 480)
    assert K.fov == pytest.approx(60)
    pose = Pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    half = np.radians(30)
    uv, _ = project([[np.sin(half) * 1e3, np.cos(half) * 1e3, 0]], pose, K, curvature=False)
    assert uv[0, 0] == pytest.approx(640, abs=1e-9)  # right edge of the image


def test_positive_tilt_moves_points_down_in_the_image():
    K = Intrinsics.from_fov(60, 640, 480)
    point = [[0.0, 1000.0, 0.0]]
    v0 = project(point, Pose(0, 0, 0, 0, 0, 0), K, curvature=False)[0][0, 1]
    v5 = project(point, Pose(0, 0, 0, 0, 5, 0), K, curvature=False)[0][0, 1]
    assert v0 == pytest.approx(240)
    assert v5 - v0 == pytest.approx(K.f_px * np.tan(np.radians(5)))  # 48.5 px down


def test_positive_swing_turns_the_horizon_counter_clockwise():
    K = Intrinsics.from_fov(60, 640, 480)
    horizon = [[np.sin(a) * 5e3, np.cos(a) * 5e3, 0.0] for a in np.radians([-20, 20])]
    uv, _ = project(horizon, Pose(0, 0, 0, 0, 0, 10), K, curvature=False)
    left, right = uv
    assert right[1] < left[1]  # right end higher: counter-clockwise on screen
    slope = np.degrees(np.arctan2(left[1] - right[1], right[0] - left[0]))
    assert slope == pytest.approx(10, abs=1e-6)


def test_pixel_rays_and_projection_are_inverse():
    K = Intrinsics(300, 200, 250.0, 140.0, 110.0)
    pose = Pose(10.0, -20.0, 5.0, 123.0, -7.0, 12.0)
    rng = np.random.default_rng(2)
    u, v = rng.uniform(0, 300, 100), rng.uniform(0, 200, 100)
    d = pixel_directions(u, v, pose, K)
    pts = np.array([10.0, -20.0, 5.0]) + d * rng.uniform(10, 5000, (100, 1))
    uv, ok = project(pts, pose, K, curvature=False)
    assert ok.all()
    np.testing.assert_allclose(uv, np.stack([u, v], 1), atol=1e-8)


def test_curvature_lowers_by_d2_times_0_87_over_2r():
    assert earth_drop(10_000.0) == pytest.approx(10_000.0**2 * 0.87 / (2 * 6_371_000), rel=1e-12)
    assert earth_drop(10_000.0) == pytest.approx(6.828, abs=1e-3)
    assert earth_drop(10_000.0, curvature=False) == 0.0
    assert CURVATURE_COEFF == pytest.approx(0.87 / 12_742_000)
    # The projection applies it: a point 20 km ahead at camera height drops below the centre row.
    K = Intrinsics.from_fov(60, 640, 480)
    v_curved = project([[0.0, 20_000.0, 0.0]], Pose(0, 0, 0, 0, 0, 0), K)[0][0, 1]
    assert v_curved - 240 == pytest.approx(K.f_px * earth_drop(20_000.0) / 20_000.0, rel=1e-9)


def test_batched_projection_equals_single():
    K = Intrinsics.from_fov(50, 400, 300)
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(-100, 100, (4, 3)), rng.uniform(0, 360, 4), rng.uniform(-10, 10, 4),
                             rng.uniform(-10, 10, 4)])
    pts = rng.uniform(-5000, 5000, (30, 3))
    uv, ok = project(pts, poses, K)
    for i in range(4):
        uv1, ok1 = project(pts, Pose.from_array(poses[i]), K)
        np.testing.assert_array_equal(ok[i], ok1)
        np.testing.assert_allclose(uv[i], uv1, equal_nan=True)
