"""Camera model (README, Conventions): pose, intrinsics, axes, projection, rays.

World frame: x east, y north, z up (metres). Angles in degrees:
``pan`` clockwise from grid north, ``tilt`` up from the horizontal,
``swing`` roll about the optical axis (positive: the camera's right side
dips, the horizon turns counter-clockwise in the image). Image: u right,
v down, origin at the top-left corner, pixel (i, j) covers [i, i+1) x [j, j+1).

Earth curvature and refraction: a point at horizontal distance d from the
camera is seen as if lowered by ``d**2 (1 - k) / (2 R)``; all functions
take ``curvature=True`` (the default) or False (flat earth).

Poses may be batched: a pose array has shape (..., 6) with columns
x, y, z, pan, tilt, swing; every function broadcasts over leading axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import InputError

EARTH_RADIUS_M = 6_371_000.0
REFRACTION_K = 0.13
#: Drop per squared metre of horizontal distance: d**2 * CURVATURE_COEFF metres.
CURVATURE_COEFF = (1.0 - REFRACTION_K) / (2.0 * EARTH_RADIUS_M)


def curvature_coeff(curvature: bool) -> float:
    """The drop coefficient c (1/m) with drop = c d**2; 0 for a flat earth."""
    return CURVATURE_COEFF if curvature else 0.0


def earth_drop(distance_m, curvature: bool = True):
    """Apparent lowering (m) of a point at horizontal distance ``distance_m``."""
    return curvature_coeff(curvature) * np.square(distance_m)


@dataclass(frozen=True)
class Pose:
    """Camera position (world metres) and orientation (degrees)."""

    x: float
    y: float
    z: float
    pan: float
    tilt: float
    swing: float

    def array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z, self.pan, self.tilt, self.swing], dtype=np.float64)

    @classmethod
    def from_array(cls, a) -> "Pose":
        return cls(*(float(v) for v in np.asarray(a, dtype=np.float64).reshape(6)))

    def normalized(self) -> "Pose":
        """Same pose with pan in [0, 360) and swing in (-180, 180]."""
        swing = -((-self.swing + 180.0) % 360.0 - 180.0) + 0.0  # + 0.0: no -0.0
        return Pose(self.x, self.y, self.z, self.pan % 360.0, self.tilt, swing)


def horizontal_fov(width: float, f_px: float) -> float:
    """Horizontal field of view (deg) of an image ``width`` px wide at focal length ``f_px`` (px): 2 atan(W / (2 f))."""
    return math.degrees(2.0 * math.atan(width / (2.0 * f_px)))


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics: image size (px), focal length f_px (px), principal point (px)."""

    width: int
    height: int
    f_px: float
    cx: float
    cy: float

    @classmethod
    def from_fov(cls, fov_deg: float, width: int, height: int, cx: float | None = None,
                 cy: float | None = None) -> "Intrinsics":
        """Intrinsics from the horizontal field of view: fov = 2 atan(W / (2 f_px))."""
        if not (0.0 < fov_deg < 180.0) or not math.isfinite(fov_deg):
            raise InputError(f"field of view must lie in (0, 180) degrees, got {fov_deg}")
        if width < 2 or height < 2:
            raise InputError(f"image size must be at least 2 x 2, got {width} x {height}")
        f_px = width / (2.0 * math.tan(math.radians(fov_deg) / 2.0))
        return cls(int(width), int(height), f_px, width / 2.0 if cx is None else cx,
                   height / 2.0 if cy is None else cy)

    @property
    def fov(self) -> float:
        """Horizontal field of view, degrees."""
        return horizontal_fov(self.width, self.f_px)

    def array(self) -> np.ndarray:
        """(f_px, cx, cy) as a float64 array."""
        return np.array([self.f_px, self.cx, self.cy], dtype=np.float64)


def as_pose_array(poses) -> np.ndarray:
    """Accept a Pose, a sequence of Poses or an array (..., 6); return float64 (..., 6)."""
    if isinstance(poses, Pose):
        return poses.array()
    if isinstance(poses, (list, tuple)) and poses and isinstance(poses[0], Pose):
        return np.stack([p.array() for p in poses])
    a = np.asarray(poses, dtype=np.float64)
    if a.shape[-1] != 6:
        raise ValueError(f"pose arrays need a last axis of 6 (x, y, z, pan, tilt, swing), got {a.shape}")
    return a


def camera_axes(pan, tilt, swing) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit right, up and forward vectors in the world frame, each (..., 3).

    forward f = (sin p cos t, cos p cos t, sin t); r0 = (cos p, -sin p, 0);
    u0 = r0 x f; right = cos s r0 - sin s u0; up = sin s r0 + cos s u0.
    """
    p, t, s = (np.radians(np.asarray(a, dtype=np.float64)) for a in (pan, tilt, swing))
    p, t, s = np.broadcast_arrays(p, t, s)
    sp, cp, st, ct, ss, cs = np.sin(p), np.cos(p), np.sin(t), np.cos(t), np.sin(s), np.cos(s)
    zero = np.zeros_like(p)
    f = np.stack([sp * ct, cp * ct, st], axis=-1)
    r0 = np.stack([cp, -sp, zero], axis=-1)
    u0 = np.stack([-sp * st, -cp * st, ct], axis=-1)
    right = cs[..., None] * r0 - ss[..., None] * u0
    up = ss[..., None] * r0 + cs[..., None] * u0
    return right, up, f


def project(points, poses, intrinsics: Intrinsics, curvature: bool = True):
    """Pinhole projection of world points for one or many poses.

    Parameters
    ----------
    points : (N, 3) world points, metres, seen by every pose; or (P, N, 3), each
        pose its own N points.
    poses : Pose or (P, 6) array.
    intrinsics : Intrinsics (shared by all poses).

    Returns
    -------
    uv : (P, N, 2) image coordinates (px) — (N, 2) for a single Pose.
    in_front : (P, N) bool, True where the point lies in front of the camera.
    """
    single = isinstance(poses, Pose) or np.ndim(poses) == 1
    pa = np.atleast_2d(as_pose_array(poses))
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    if points.ndim == 2:
        points = points[None, :, :]
    right, up, fwd = camera_axes(pa[:, 3], pa[:, 4], pa[:, 5])
    # per coordinate on (P, N) arrays rather than (P, N, 3) stacks and einsums: 6x faster on
    # the thousands of poses x features of the "skyline is the limit" test
    dx = points[..., 0] - pa[:, 0:1]
    dy = points[..., 1] - pa[:, 1:2]
    c = curvature_coeff(curvature)
    dz = (points[..., 2] - c * (dx * dx + dy * dy) if c else points[..., 2]) - pa[:, 2:3]

    def along(axis: np.ndarray) -> np.ndarray:
        return dx * axis[:, 0:1] + dy * axis[:, 1:2] + dz * axis[:, 2:3]

    zc, xc, yc = along(fwd), along(right), along(up)
    in_front = zc > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        u = intrinsics.cx + intrinsics.f_px * xc / zc
        v = intrinsics.cy - intrinsics.f_px * yc / zc
    uv = np.stack([np.where(in_front, u, np.nan), np.where(in_front, v, np.nan)], axis=-1)
    return (uv[0], in_front[0]) if single else (uv, in_front)


def pixel_ray_basis(poses, intrinsics_array) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-pose linear ray model: the (unnormalised) world direction through
    image point (u, v) is ``d0 + u * du + v * dv``.

    ``intrinsics_array`` is (f_px, cx, cy), shape (3,) or (P, 3).
    Returns d0, du, dv, each (P, 3).
    """
    pa = np.atleast_2d(as_pose_array(poses))
    k = np.broadcast_to(np.asarray(intrinsics_array, dtype=np.float64), (len(pa), 3))
    f_px, cx, cy = k[:, 0:1], k[:, 1:2], k[:, 2:3]
    right, up, fwd = camera_axes(pa[:, 3], pa[:, 4], pa[:, 5])
    du = right / f_px
    dv = -up / f_px
    d0 = fwd - cx * du - cy * dv
    return d0, du, dv


def pixel_directions(u, v, pose, intrinsics: Intrinsics) -> np.ndarray:
    """Unit world directions through image points (u, v) of one pose, shape (..., 3)."""
    d0, du, dv = pixel_ray_basis(pose, intrinsics.array())
    u = np.asarray(u, dtype=np.float64)[..., None]
    v = np.asarray(v, dtype=np.float64)[..., None]
    d = d0[0] + u * du[0] + v * dv[0]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def mitsuba_to_world(pose: Pose, origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4 x 4 camera-to-world matrix in Mitsuba's camera frame convention
    (+x left, +y up, +z forward), with the camera position taken relative to
    ``origin`` (the terrain's local origin)."""
    right, up, fwd = camera_axes(pose.pan, pose.tilt, pose.swing)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = -right, up, fwd
    m[:3, 3] = np.array([pose.x, pose.y, pose.z]) - np.asarray(origin, dtype=np.float64)
    return m
