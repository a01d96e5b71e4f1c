"""Stage 3b — pose from three correspondences (Naval 2000, section 2.2), vectorised.

Every hypothesis pairs three image points (u, v) with three world points. The
camera stands ``height`` metres above the ground, so its position has two
unknowns (x, y) and z = g(x, y) + height; with pan, tilt and swing that makes
five unknowns against six equations. Solved for all hypotheses at once:

1. Position, closed form (Snellius–Pothenot resection): the angle between two
   image bearings is independent of the camera's rotation, so the camera lies on
   the circle through the two world points on which they subtend that angle;
   two such circles (pairs left-middle, middle-right) meet at the middle point
   and at the camera.
2. Position, Gauss–Newton on the three inter-bearing angles with the height
   constraint and earth curvature (the closed form treats the angles as
   horizontal ones).
3. Rotation, closed form (Kabsch / Wahba) between the camera bearings and the
   world directions; pan, tilt, swing read off it.
4. Reprojection residual (px) of the three points: the hypothesis test.

Conventions: the README (world x east, y north, z up; angles in degrees).
"""

from __future__ import annotations

import numpy as np

from ..camera import curvature_coeff
from ..dem import DEM

#: Closed-form rounds with the elevation correction (then ``gn_iterations`` Gauss–Newton steps).
RESECTION_ROUNDS = 2
#: Finite-difference step (m) for the position Jacobian.
FD_STEP_M = 1.0


def image_bearings(uv: np.ndarray, f_px, cx: float, cy: float) -> np.ndarray:
    """Unit bearings in the camera frame (right, up, forward) of image points.

    uv : (..., 2) pixel coordinates; f_px : focal length (px), scalar or
    broadcastable to uv's leading shape. Returns (..., 3).
    """
    uv = np.asarray(uv, dtype=np.float64)
    f = np.asarray(f_px, dtype=np.float64)
    b = np.stack([(uv[..., 0] - cx) / f, -(uv[..., 1] - cy) / f, np.ones(uv.shape[:-1])], axis=-1)
    return b / np.linalg.norm(b, axis=-1, keepdims=True)


def _pair_angles(b: np.ndarray) -> np.ndarray:
    """(..., 3) angles (rad) between bearings 0-1, 1-2, 0-2 of (..., 3, 3) unit vectors."""
    dots = np.stack([b[..., 0, 0] * b[..., 1, 0] + b[..., 0, 1] * b[..., 1, 1] + b[..., 0, 2] * b[..., 1, 2],
                     b[..., 1, 0] * b[..., 2, 0] + b[..., 1, 1] * b[..., 2, 1] + b[..., 1, 2] * b[..., 2, 2],
                     b[..., 0, 0] * b[..., 2, 0] + b[..., 0, 1] * b[..., 2, 1] + b[..., 0, 2] * b[..., 2, 2]], axis=-1)
    return np.arccos(np.clip(dots, -1.0, 1.0))


def resection_2d(points_xy: np.ndarray, angle_lm: np.ndarray, angle_mr: np.ndarray) -> np.ndarray:
    """Closed-form camera position from three map points seen left, middle, right.

    points_xy : (N, 3, 2) world x, y of the left, middle and right points.
    angle_lm, angle_mr : (N,) angles (rad, in (0, pi)) the camera sees between
        left-middle and middle-right. Left to right in the image is clockwise
        seen from above.
    Returns (N, 2); NaN where the two circles coincide (the camera on the circle
    through all three points: no unique solution).
    """
    left, mid, right = points_xy[:, 0], points_xy[:, 1], points_xy[:, 2]

    def centre(a, b, theta):
        # circle through a, b on which the counter-clockwise angle from (P->a) to (P->b) is theta
        m = 0.5 * (a + b)
        ab = b - a
        normal = np.stack([-ab[:, 1], ab[:, 0]], axis=1)  # ab turned counter-clockwise
        with np.errstate(divide="ignore", invalid="ignore"):
            return m + 0.5 / np.tan(theta)[:, None] * normal

    # clockwise left -> right is counter-clockwise right -> left
    o1 = centre(mid, left, angle_lm)
    o2 = centre(right, mid, angle_mr)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        d = o2 - o1
        dd = np.sum(d * d, axis=1)
        t = np.sum((mid - o1) * d, axis=1) / dd
        foot = o1 + t[:, None] * d
        out = 2.0 * foot - mid  # the middle point mirrored over the line of centres
    out[~(dd > 1e-6 * np.sum((left - right) ** 2, axis=1))] = np.nan
    return out


def horizontal_angles(measured: np.ndarray, elevations: np.ndarray) -> np.ndarray:
    """Horizontal angles (rad) between bearings from their 3-D angles and elevations.

    measured : (N, 3) angles of pairs 0-1, 1-2, 0-2; elevations : (N, 3) angles (rad)
    of the three directions above the horizontal. Spherical law of cosines:
    cos(theta) = cos e_i cos e_j cos(delta) + sin e_i sin e_j.
    """
    e = elevations
    pairs = ((0, 1), (1, 2), (0, 2))
    out = []
    for k, (i, j) in enumerate(pairs):
        cos_delta = (np.cos(measured[:, k]) - np.sin(e[:, i]) * np.sin(e[:, j])) / (np.cos(e[:, i]) * np.cos(e[:, j]))
        out.append(np.arccos(np.clip(cos_delta, -1.0, 1.0)))
    return np.stack(out, axis=1)


def plausible_positions(dem: DEM, xy: np.ndarray, world: np.ndarray, measured: np.ndarray,
                        min_distance_m: float = 100.0) -> np.ndarray:
    """(N,) bool: a first position estimate worth refining — on the DEM, not on top of
    a point, and seeing the points left to right (clockwise) at angles near the measured ones.

    The closed form meets both circles also on their other arcs, where the points appear
    in the wrong order; and its angles are 3-D ones, so a loose tolerance applies.
    """
    ok = np.isfinite(xy).all(axis=1)
    ok[ok] = dem.contains(xy[ok, 0], xy[ok, 1])
    dx = world[..., 0] - xy[:, None, 0]
    dy = world[..., 1] - xy[:, None, 1]
    ok &= np.all(dx * dx + dy * dy >= min_distance_m**2, axis=1)
    az = np.arctan2(dx, dy)  # clockwise from north
    for (i, j), k in (((0, 1), 0), ((1, 2), 1)):
        turn = (az[:, j] - az[:, i]) % (2 * np.pi)
        ok &= (turn < np.pi) & (np.abs(turn - measured[:, k]) <= 0.5 * measured[:, k] + np.radians(1.0))
    return ok


def camera_centres(dem: DEM, xy: np.ndarray, height: float) -> np.ndarray:
    """(..., 3) camera centres at positions xy (..., 2) (m), ``height`` m above the ground
    (z NaN outside the DEM)."""
    return np.concatenate([xy, (dem.ground(xy[..., 0], xy[..., 1]) + height)[..., None]], axis=-1)


def _world_directions(points: np.ndarray, centres: np.ndarray, c: float) -> np.ndarray:
    """(N, 3, 3) unit directions from each centre (N, 3) to its points (N, 3, 3), as seen (lowered)."""
    rx = points[..., 0] - centres[:, None, 0]
    ry = points[..., 1] - centres[:, None, 1]
    rz = points[..., 2] - centres[:, None, 2]
    if c:
        rz = rz - c * (rx * rx + ry * ry)
    inv = 1.0 / np.sqrt(rx * rx + ry * ry + rz * rz)
    return np.stack([rx * inv, ry * inv, rz * inv], axis=-1)


def _angles_and_jacobian(dem: DEM, xy: np.ndarray, world: np.ndarray, height: float,
                         c: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The three inter-point angles (N, 3) (rad) seen from positions xy (N, 2), z = g + height,
    and their forward-difference derivatives along x and along y (rad/m), each (N, 3)."""
    def angles(p):
        return _pair_angles(_world_directions(world, camera_centres(dem, p, height), c))

    a0 = angles(xy)
    return a0, (angles(xy + (FD_STEP_M, 0.0)) - a0) / FD_STEP_M, (angles(xy + (0.0, FD_STEP_M)) - a0) / FD_STEP_M


def refine_positions(dem: DEM, xy: np.ndarray, world: np.ndarray, measured: np.ndarray, height: float,
                     c: float, iterations: int = 5) -> np.ndarray:
    """Gauss–Newton on (x, y): match the three inter-bearing angles, z = g + height.

    xy : (N, 2) start; world : (N, 3, 3) points; measured : (N, 3) angles (rad).
    Forward-difference Jacobian; the 2 x 2 normal equations are solved in closed form.
    """
    xy = xy.copy()
    for _ in range(iterations):
        a0, jx, jy = _angles_and_jacobian(dem, xy, world, height, c)
        r = a0 - measured
        a, b, d = (jx * jx).sum(1), (jx * jy).sum(1), (jy * jy).sum(1)
        gx, gy = (jx * r).sum(1), (jy * r).sum(1)
        det = a * d - b * b
        with np.errstate(divide="ignore", invalid="ignore"):
            dx = -(d * gx - b * gy) / det
            dy = -(a * gy - b * gx) / det
        # a step may go at most half-way to the nearest point
        reach = 0.5 * np.min(np.hypot(world[..., 0] - xy[:, None, 0], world[..., 1] - xy[:, None, 1]), axis=1)
        scale = np.minimum(1.0, reach / np.maximum(np.hypot(dx, dy), 1e-9))
        xy = xy + np.stack([dx * scale, dy * scale], axis=1)
    return xy


def position_uncertainty(dem: DEM, xy: np.ndarray, world: np.ndarray, height: float, c: float,
                         angle_noise_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Axes and standard deviations (m) of three-point positions (x, y) when the
    inter-bearing angles carry ``angle_noise_rad`` of noise.

    xy : (2,) position, or (N, 2); world : (3, 3) its matched points, or (N, 3, 3). From
    the Jacobian J of the three angles with respect to (x, y): covariance = noise^2
    (J^T J)^-1. Distant peaks seen from 2 m leave hundreds of metres of doubt, and the
    long axis is rarely the viewing direction. Returns (axes (2, 2), columns weak then
    strong; sigma (2,) in metres, weak first), or (N, 2, 2) and (N, 2) for N positions.
    """
    xy, world = np.asarray(xy, np.float64), np.asarray(world, np.float64)
    one = xy.ndim == 1
    _, jx, jy = _angles_and_jacobian(dem, xy.reshape(-1, 2), world.reshape(-1, 3, 3), height, c)
    J = np.stack([jx, jy], axis=-1)  # (N, 3 angles, 2)
    eig, axes = np.linalg.eigh(np.einsum("nki,nkj->nij", J, J))  # ascending: weak axis first
    with np.errstate(divide="ignore"):
        sigma = angle_noise_rad / np.sqrt(np.maximum(eig, 0.0))
    return (axes[0], sigma[0]) if one else (axes, sigma)


def _unit(a: np.ndarray) -> np.ndarray:
    return a / np.sqrt((a * a).sum(axis=1, keepdims=True))


def _triad(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Symmetric orthonormal frame of three directions (N, 3, 3): the mean
    direction, then the left-to-right direction made orthogonal to it, then their cross product."""
    e1 = _unit(v[:, 0] + v[:, 1] + v[:, 2])
    spread = v[:, 2] - v[:, 0]
    e2 = _unit(spread - (spread * e1).sum(axis=1, keepdims=True) * e1)
    return e1, e2, np.cross(e1, e2)


def rotations_from_bearings(bearings: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(N, 3, 3) matrices R (columns: right, up, forward in world) with R b ~ w,
    from camera bearings b and world directions w, both (N, 3 points, 3).

    Closed form: the same symmetric frame (:func:`_triad`) built from the bearings
    and from the directions is matched. The camera frame (right, up, forward) is
    left-handed (README, Conventions: up = right x forward), so the bearing frame's third
    axis is negated and R has determinant -1.
    """
    b1, b2, b3 = _triad(bearings)
    w1, w2, w3 = _triad(directions)
    return w1[:, :, None] * b1[:, None, :] + w2[:, :, None] * b2[:, None, :] - w3[:, :, None] * b3[:, None, :]


def angles_from_rotations(R: np.ndarray) -> np.ndarray:
    """(N, 3) pan, tilt, swing (degrees; pan in [0, 360)) of rotations with columns right, up, forward."""
    right, fwd = R[:, :, 0], R[:, :, 2]
    tilt = np.arcsin(np.clip(fwd[:, 2], -1.0, 1.0))
    pan = np.arctan2(fwd[:, 0], fwd[:, 1])
    sp, cp, st, ct = np.sin(pan), np.cos(pan), np.sin(tilt), np.cos(tilt)
    r0 = np.stack([cp, -sp, np.zeros_like(pan)], axis=1)
    u0 = np.stack([-sp * st, -cp * st, ct], axis=1)
    swing = np.arctan2(-np.sum(right * u0, axis=1), np.sum(right * r0, axis=1))
    return np.column_stack([np.degrees(pan) % 360.0, np.degrees(tilt), np.degrees(swing)])


def poses_at(centres: np.ndarray, world: np.ndarray, bearings: np.ndarray,
             c: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Poses (N, 6) standing at camera centres (N, 3), turned so that the camera
    bearings (N, 3, 3) point at the world points (N, 3, 3); c: curvature coefficient.

    Also returns the rotations (N, 3, 3) and the world directions (N, 3, 3) they used.
    """
    dirs = _world_directions(world, centres, c)
    R = rotations_from_bearings(bearings, dirs)
    return np.column_stack([centres, angles_from_rotations(R)]), R, dirs


def solve_poses(dem: DEM, image_uv: np.ndarray, world: np.ndarray, height: float, f_px, cx: float, cy: float,
                curvature: bool = True, gn_iterations: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Camera poses from three correspondences each, all hypotheses at once.

    Parameters
    ----------
    dem : ground g(x, y) for the height constraint.
    image_uv : (N, 3, 2) image points (px), ordered left to right (increasing u).
    world : (N, 3, 3) the matched world points (m).
    height : camera height above ground (m).
    f_px : focal length (px), scalar or (N,); cx, cy : principal point (px).
    gn_iterations : Gauss–Newton steps on the position after the closed form.

    Returns
    -------
    poses : (N, 6) x, y, z, pan, tilt, swing (NaN where no solution).
    residual : (N,) RMS reprojection error of the three points (px); inf where no solution.
    """
    world = np.asarray(world, dtype=np.float64)
    N = len(world)
    f = np.broadcast_to(np.asarray(f_px, dtype=np.float64), (N,))
    bearings = image_bearings(image_uv, f[:, None], cx, cy)
    measured = _pair_angles(bearings)
    c = curvature_coeff(curvature)
    # closed form on the 3-D angles, then again on horizontal angles from the elevations
    # the points show from the last estimate (a fixed point that settles in a few rounds)
    xy = resection_2d(world[:, :, :2], measured[:, 0], measured[:, 1])
    poses = np.full((N, 6), np.nan)
    residual = np.full(N, np.inf)
    # most hypotheses are hopeless already here: continue with the plausible ones only
    keep = np.flatnonzero(plausible_positions(dem, xy, world, measured))
    if len(keep) == 0:
        return poses, residual
    xy, world, measured, bearings, f = xy[keep], world[keep], measured[keep], bearings[keep], f[keep]
    image_uv = np.asarray(image_uv, dtype=np.float64)[keep]
    for _ in range(RESECTION_ROUNDS):
        dirs = _world_directions(world, camera_centres(dem, xy, height), c)
        flat = horizontal_angles(measured, np.arcsin(np.clip(dirs[..., 2], -1.0, 1.0)))
        xy = np.where(np.isfinite(flat).all(axis=1, keepdims=True),
                      resection_2d(world[:, :, :2], flat[:, 0], flat[:, 1]), xy)
    xy = refine_positions(dem, xy, world, measured, height, c, gn_iterations)
    centres = camera_centres(dem, xy, height)
    ok = np.zeros(N, dtype=bool)
    ok[keep] = np.all(np.isfinite(centres), axis=1)
    if not ok.any():
        return poses, residual
    bearings, f, image_uv, world = bearings[ok[keep]], f[ok[keep]], image_uv[ok[keep]], world[ok[keep]]
    poses[ok], R, dirs = poses_at(centres[ok[keep]], world, bearings, c)
    # reprojection: camera-frame coordinates of the world directions
    cam = (R[:, None, :, :] * dirs[:, :, :, None]).sum(axis=2)  # R^T w: (n, 3 points, right/up/forward)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = cx + f[:, None] * cam[..., 0] / cam[..., 2]
        v = cy - f[:, None] * cam[..., 1] / cam[..., 2]
    err = np.sqrt(np.mean((u - image_uv[:, :, 0]) ** 2 + (v - image_uv[:, :, 1]) ** 2, axis=1))
    err[~np.all(cam[..., 2] > 0, axis=1)] = np.inf
    residual[ok] = np.where(np.isfinite(err), err, np.inf)
    return poses, residual
