"""Stage 4b — refinement of a verified pose against the photo's skyline.

1. Local search (coarse to fine) over (x, y) around the pose: every grid
   position is rendered in one batch with the pose's orientation, and the
   rendered skyline is aligned to the photo's by a 2-D shift and slope (what
   small pan, tilt and swing changes do to a skyline); the best aligned
   position wins and its alignment corrects the orientation. A camera 2 m above
   rough ground sees its foreground ridges move by pixels per metre, so a plain
   gradient method from a pose tens of metres off stalls; the grid does not.
2. Sub-pixel least squares (``scipy.optimize.least_squares``, soft-L1 loss)
   over (pan, tilt, swing), then (x, y, pan, tilt, swing), and the focal length
   too when it is unknown; z stays g(x, y) + height. The Jacobian comes from one
   batched render of the pose and its forward-difference neighbours.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from ..camera import Intrinsics, curvature_coeff, project
from ..render import Terrain, render_skylines
from ..render.skyline import strided_skylines
from ..render.visibility import line_of_sight
from .pose_solver import camera_centres, image_bearings, poses_at, position_uncertainty
from .verification import SHIFTS_PX, ScoreParams, align_skylines, column_errors, score_skylines, verify_poses

#: Forward-difference steps: metres for x, y; degrees for the angles; relative for f.
STEP_XY_M = 2.0
STEP_DEG = 0.01
STEP_F_REL = 1e-3
STEP_H_M = 1.0
#: Bisection tolerance (px) of the renders inside the fit: well below the steps' effect.
FIT_TOL_PX = 0.01


@dataclass(frozen=True)
class Refined:
    """A refined pose (x, y, z, pan, tilt, swing), its focal length (px), score and agreement."""

    pose: np.ndarray
    f_px: float
    score: float
    agreement: float
    evaluations: int


@dataclass(frozen=True)
class RefineParams:
    """The refinement's search set-up (:func:`refine_pose`); every field settable from an experiment.

    Local search: ``search_levels`` are half-widths (m) along and across the line of sight and
    grid points (along x across); without matched points the first (wide) level finds the area,
    the last two serve a camera at a crest's edge, whose foreground changes per metre.
    ``fine_shift_px``: horizontal shifts (+-, 1 px steps) tried by the alignment after the first
    level (that level's alignment has corrected the orientation; a pixel or two remain).
    Resection sweep (with matched points): positions over the three-point position's
    uncertainty ellipse (:func:`position_uncertainty`, apex noise ``apex_noise_px``) out to
    ``sweep_sigmas``, half-widths clipped to ``sweep_half_width_m``, ``sweep_spacing_m`` apart
    (coarser when the ellipse would need more than ``sweep_max_poses``), each turned to its
    three points and rendered on every ``sweep_stride``-th column without alignment.
    """

    search_levels: tuple = ((640.0, 160.0, 65, 9), (40.0, 40.0, 5, 5), (12.0, 12.0, 5, 5), (3.0, 3.0, 5, 5),
                            (1.0, 1.0, 5, 5), (0.3, 0.3, 5, 5))
    search_beam: int = 3  # best positions of each level kept as the next level's seeds
    search_max_poses: int = 200  # at most this many positions per seed and level are rendered (evenly thinned)
    fine_shift_px: float = 4.0
    apex_noise_px: float = 2.0
    sweep_sigmas: float = 2.5
    sweep_half_width_m: tuple = (30.0, 1200.0)
    sweep_spacing_m: float = 10.0
    sweep_max_poses: int = 6000
    sweep_stride: int = 8
    max_nfev: int = 30  # least-squares evaluations per stage
    # the last least-squares stage also fits the camera height within [0, height + this] m
    # (0: fixed). Real photos: the height above the DEM's surface is unknown on a slope (SRTM's
    # 90 m cells), and the oracle fit at the true positions found 0-29 m (``make oracle``). Not
    # in the photo preset: on 10 CH1 training photos, 50 m moved the four right answers by
    # -23..+23 m (185-571 m off before) and no wrong one within 1 km, and the fitted heights
    # ran to the bound on four (experiments/ch1/README.md)
    fit_height_m: float = 0.0


def resection_sweep(terrain: Terrain, pose: np.ndarray, intrinsics: Intrinsics, height: float,
                    image_skyline: np.ndarray, weights: np.ndarray, f_px: float, points: np.ndarray,
                    params: ScoreParams = ScoreParams(),
                    refine: RefineParams = RefineParams()) -> tuple[list[np.ndarray], float, float, int]:
    """The ``refine.search_beam`` best positions (at least one grid step apart) over the uncertainty
    ellipse of a three-point pose, each turned to show its three points where ``pose``
    shows them.

    A camera a few metres above rough ground sees its foreground change within ten
    metres, so the skyline matches only in a small dip, while three distant points
    leave hundreds of metres of doubt, and not along the viewing direction: a dense
    grid over that doubt, cheap renders, orientation from the points. Returns
    (seeds, the best score in px (NaN when nothing could be swept), grid spacing in m,
    renders used)."""
    dem = terrain.dem
    c = curvature_coeff(terrain.curvature)
    points = np.asarray(points, np.float64)
    k_full = replace(intrinsics, f_px=f_px)
    uv, _ = project(points, pose[None], k_full, terrain.curvature)
    bearings = image_bearings(uv[0], f_px, intrinsics.cx, intrinsics.cy)
    axes, sigma = position_uncertainty(dem, np.asarray(pose[:2], np.float64), points, height, c, refine.apex_noise_px / f_px)
    if not (np.all(np.isfinite(sigma)) and np.all(np.isfinite(bearings))):
        return [pose], np.nan, refine.sweep_spacing_m, 0
    half = np.clip(refine.sweep_sigmas * sigma, *refine.sweep_half_width_m)
    spacing = max(refine.sweep_spacing_m, float(np.sqrt(4 * half[0] * half[1] / refine.sweep_max_poses)))
    n = np.maximum(3, np.ceil(2 * half / spacing).astype(int) + 1)
    gw, gs = np.meshgrid(np.linspace(-half[0], half[0], n[0]), np.linspace(-half[1], half[1], n[1]))
    xy = pose[:2] + gw.reshape(-1, 1) * axes[:, 0] + gs.reshape(-1, 1) * axes[:, 1]
    centres = camera_centres(dem, xy, height)
    centres = centres[np.isfinite(centres[:, 2])]
    if len(centres) == 0:
        return [pose], np.nan, spacing, 0
    centres = centres[_sees_all(terrain, centres, points)]
    if len(centres) == 0:
        return [pose], np.nan, spacing, 0
    n_pos = len(centres)
    poses, _, _ = poses_at(centres, np.broadcast_to(points, (n_pos, 3, 3)), np.broadcast_to(bearings, (n_pos, 3, 3)), c)
    rendered, cols = strided_skylines(terrain, poses, k_full, refine.sweep_stride, tol_px=0.25)
    score, _ = score_skylines(rendered, image_skyline[cols], weights[cols], params)
    return best_apart(poses, score, refine.search_beam, spacing), float(score.min()), spacing, n_pos


@dataclass(frozen=True)
class WeakSweepParams:
    """The weak-axis sweep of three-point poses before the localizer abstains (:func:`weak_axis_sweep`).

    ``chunks``: the verified three-point poses of the first this many chunks (the most
    probable hypotheses) are swept (0: off). A pose whose position doubt (:func:`position_uncertainty`,
    apex noise ``apex_noise_px``) exceeds ``min_sigma_m`` along its weak axis is moved along it
    out to ``sigmas`` of that doubt (at most ``max_half_m``), ``spacing_m`` apart, turned to its
    three points at each step and verified on every ``stride``-th column; at most ``max_positions``
    positions in all (~3 s), the poses taken in the order given (the most probable hypotheses first).
    """

    chunks: int = 1
    min_sigma_m: float = 50.0
    apex_noise_px: float = 2.0
    sigmas: float = 2.5
    max_half_m: float = 600.0
    spacing_m: float = 10.0  # a camera 2 m above rough ground matches its foreground within ~15 m
    stride: int = 16
    # bench-localize view 7 needed 15,706 (its first chunk's 194 weak poses); a whole tile's first chunk held
    # enough for 44 s of sweeping (experiments/scale/README.md)
    max_positions: int = 16_000


def weak_axis_sweep(terrain: Terrain, poses: np.ndarray, points: np.ndarray, image_uv: np.ndarray,
                    intrinsics: Intrinsics, height: float, image_skyline: np.ndarray, weights: np.ndarray,
                    sweep: WeakSweepParams = WeakSweepParams(),
                    params: ScoreParams = ScoreParams()) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Weakly held three-point poses moved along their weak axis to where their skyline fits best.

    Three peaks close together in the image fix the camera's position to within hundreds of
    metres along one axis: solved from peaks a pixel off, the right hypothesis lands a few
    hundred metres from the camera, where the near foreground differs and its verification
    score ranks it among the wrong ones. Each such pose is moved along that axis, turned at
    every step so that its image peaks ``image_uv`` (P, 3, 2) px point at its ``points``
    (P, 3, 3) m, and verified (:func:`verify_poses`, aligned, every ``sweep.stride``-th column).

    Returns (indices of the swept poses (S,), their best poses (S, 6), plain scores (S,) and
    trusted scores (S,) in px); empty when none is weakly held."""
    poses, points = np.asarray(poses, np.float64), np.asarray(points, np.float64)
    empty = (np.zeros(0, np.int64), np.zeros((0, 6)), np.zeros(0), np.zeros(0))
    if len(poses) == 0:
        return empty
    c = curvature_coeff(terrain.curvature)
    axes, sigma = position_uncertainty(terrain.dem, poses[:, :2], points, height, c,
                                       sweep.apex_noise_px / intrinsics.f_px)
    weak = np.flatnonzero(np.isfinite(sigma[:, 0]) & (sigma[:, 0] > sweep.min_sigma_m))
    if len(weak) == 0:
        return empty
    steps = np.ceil(np.minimum(sweep.sigmas * sigma[weak, 0], sweep.max_half_m) / sweep.spacing_m).astype(np.int64)
    within = np.cumsum(2 * steps + 1) <= sweep.max_positions  # the first poses, up to the budget
    weak, steps = weak[within], steps[within]
    if len(weak) == 0:
        return empty
    counts = 2 * steps + 1  # the steps of one pose are contiguous, from -steps to +steps
    owner = np.repeat(np.arange(len(weak)), counts)
    start = np.r_[0, np.cumsum(counts)[:-1]]
    offset = sweep.spacing_m * (np.arange(len(owner)) - start[owner] - steps[owner])
    xy = poses[weak[owner], :2] + offset[:, None] * axes[weak[owner], :, 0]
    centres = camera_centres(terrain.dem, xy, height)
    on_dem = np.flatnonzero(np.isfinite(centres[:, 2]))
    bearings = image_bearings(image_uv[weak], intrinsics.f_px, intrinsics.cx, intrinsics.cy)
    moved, _, _ = poses_at(centres[on_dem], points[weak[owner[on_dem]]], bearings[owner[on_dem]], c)
    score, trusted = np.full(len(xy), np.inf), np.full(len(xy), np.inf)
    score[on_dem], trusted[on_dem] = verify_poses(terrain, moved, intrinsics, image_skyline, weights, sweep.stride,
                                                  params)
    full = np.zeros((len(xy), 6))
    full[on_dem] = moved
    # each swept pose's best step (the first of equals)
    order = np.lexsort((np.arange(len(xy)), score, owner))
    best = order[start]
    found = np.isfinite(score[best])
    return weak[found], full[best[found]], score[best[found]], trusted[best[found]]


def best_apart(poses: np.ndarray, score: np.ndarray, beam: int, spacing: float) -> list[np.ndarray]:
    """The ``beam`` lowest-scoring poses whose positions lie at least ``spacing`` (m) apart."""
    seeds: list[np.ndarray] = []
    for j in np.argsort(score):
        if len(seeds) == beam:
            break
        if all(np.hypot(*(poses[j, :2] - s_[:2])) >= spacing for s_ in seeds):
            seeds.append(poses[j].copy())
    return seeds


def _sees_all(terrain: Terrain, centres: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n,) bool: camera centres (n, 3) with a clear line of sight to every one of ``points`` (m, 3)."""
    sees = line_of_sight(terrain, np.repeat(centres, len(points), axis=0), np.tile(points, (len(centres), 1)))
    return sees.reshape(len(centres), len(points)).all(axis=1)


def _box_offsets(pose: np.ndarray, along_m: float, across_m: float, n_along: int, n_across: int) -> np.ndarray:
    """(..., n, 2) world offsets (m) on a grid aligned with each pose's viewing direction (pan),
    for one pose (6,) or many (P, 6)."""
    ga, gc = np.meshgrid(np.linspace(-along_m, along_m, n_along), np.linspace(-across_m, across_m, n_across))
    ga, gc = ga.ravel(), gc.ravel()
    pan = np.radians(np.asarray(pose, np.float64)[..., 3])[..., None]
    return np.stack([ga * np.sin(pan) + gc * np.cos(pan), ga * np.cos(pan) - gc * np.sin(pan)], axis=-1)


def realigned(poses: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray, f_px: float) -> np.ndarray:
    """Poses (P, 6) turned by an alignment of their rendered skylines (:func:`align_skylines`):
    the skyline moved right by a px = pan left by a / f; down by b px = tilt up; slope c = swing -c."""
    out = np.array(poses, np.float64)
    out[:, 3] = (out[:, 3] - np.degrees(np.arctan(a / f_px))) % 360.0
    out[:, 4] = out[:, 4] + np.degrees(np.arctan(b / f_px))
    out[:, 5] = out[:, 5] - np.degrees(np.arctan(c))
    return out


def local_rescore(terrain: Terrain, poses: np.ndarray, intrinsics: Intrinsics, height: float,
                  image_skyline: np.ndarray, weights: np.ndarray, half_m: float = 250.0, n: int = 5,
                  stride: int = 4, params: ScoreParams = ScoreParams()) -> tuple[np.ndarray, np.ndarray]:
    """One wide level of :func:`local_search` for many poses (P, 6) at once: each pose's
    position moved over an n x n grid +-``half_m`` (m) along and across its line of sight,
    every grid pose rendered on every ``stride``-th column in one batch and aligned to the
    photo's skyline (:func:`align_skylines`), the best kept per pose. Returns (P, 6) poses
    (their orientation corrected by the alignment) and their (P,) plain scores (px; inf where
    no grid position lies on the DEM).

    Why: far-horizon poses lie on a grid 500 m apart, and the verification scores each
    where it lies; one a few hundred metres from the truth can score worse than wrong
    places, where the same search around it scores best (on 21 CH1 dev photos it put a
    pose within 1 km first for 11, the raw score for 8, ``experiments/ch1/README.md``)."""
    poses = np.asarray(poses, np.float64)
    P = len(poses)
    if P == 0:
        return poses.copy(), np.zeros(0)
    xy = (poses[:, None, :2] + _box_offsets(poses, half_m, half_m, n, n)).reshape(-1, 2)
    grid = np.column_stack([camera_centres(terrain.dem, xy, height), np.repeat(poses[:, 3:], n * n, axis=0)])
    ok = np.isfinite(grid[:, 2])
    score = np.full(len(grid), np.inf)
    if ok.any():
        rendered, cols = strided_skylines(terrain, grid[ok], intrinsics, stride, tol_px=0.5)
        s, _, a, b, c = align_skylines(rendered, image_skyline[cols], cols, intrinsics.cx, weights[cols], params=params,
                                       swing=grid[ok][:, 5], agreement=False)
        score[ok] = s
        grid[ok] = realigned(grid[ok], a, b, c, intrinsics.f_px)
    score = score.reshape(P, n * n)
    best = np.argmin(score, axis=1)
    pick = np.arange(P) * n * n + best
    out = np.where(np.isfinite(score[np.arange(P), best])[:, None], grid[pick], poses)
    return out, score[np.arange(P), best]


def local_search(terrain: Terrain, seeds: list[np.ndarray], intrinsics: Intrinsics, height: float,
                 image_skyline: np.ndarray, weights: np.ndarray, f_px: float, stride: int = 2,
                 points: np.ndarray | None = None, params: ScoreParams = ScoreParams(),
                 widest_m: float = np.inf, give_up_px: float = np.inf,
                 refine: RefineParams = RefineParams()) -> tuple[np.ndarray, int, bool]:
    """Coarse-to-fine grid search over (x, y) around ``seeds`` (poses (6,)), elongated
    along the line of sight, with the orientation re-aligned per position
    (:func:`align_skylines`); levels of ``refine.search_levels`` no wider than ``widest_m``.
    The ``refine.search_beam`` best positions of each level (at least a grid step apart) seed the
    next: the score is flat along the line of sight and one seed can fall into the
    wrong dip. ``points`` (n, 3): the hypothesis' matched feature points; positions
    from which one of them is hidden are not rendered (a camera 2 m up sees its peaks
    from narrow strips of ground only). The search stops after its first level when the
    best pose there scores worse than ``give_up_px``. Returns the best pose, the number
    of renders used and whether it gave up."""
    dem = terrain.dem
    k_full = replace(intrinsics, f_px=f_px)
    seeds, renders = [np.asarray(seed, np.float64).copy() for seed in seeds], 0
    levels = [lv for lv in refine.search_levels if lv[0] <= widest_m]
    fine_shifts = np.arange(-refine.fine_shift_px, refine.fine_shift_px + 0.01, 1.0)
    for n_level, level in enumerate(levels):
        grids = []
        for seed in seeds:
            xy = seed[:2] + _box_offsets(seed, *level)
            grid = np.column_stack([camera_centres(dem, xy, height), np.tile(seed[3:], (len(xy), 1))])
            grid = grid[np.isfinite(grid[:, 2])]
            if points is not None and len(grid):
                grid = grid[_sees_all(terrain, grid[:, :3], points)]
            if len(grid) > refine.search_max_poses:
                grid = grid[np.linspace(0, len(grid) - 1, refine.search_max_poses).astype(np.int64)]
            grids.append(grid)
        poses = np.concatenate(grids)
        if len(poses) == 0:
            break
        rendered, cols = strided_skylines(terrain, poses, k_full, stride, tol_px=0.1)
        renders += len(poses)
        score, _, a, b, c = align_skylines(rendered, image_skyline[cols], cols, intrinsics.cx, weights[cols],
                                           shifts=SHIFTS_PX if n_level == 0 else fine_shifts, params=params,
                                           swing=poses[:, 5], agreement=False)
        poses = realigned(poses, a, b, c, f_px)
        spacing = min(2 * level[1] / max(level[3] - 1, 1), 2 * level[0] / max(level[2] - 1, 1))
        seeds = best_apart(poses, score, refine.search_beam, spacing)
        if n_level == 0 and score.min() > give_up_px:
            return seeds[0], renders, True
    return seeds[0], renders, False


def refine_pose(terrain: Terrain, pose: np.ndarray, intrinsics: Intrinsics, height: float,
                image_skyline: np.ndarray, weights: np.ndarray, *, fit_focal: bool = False,
                f_px: float | None = None, points: np.ndarray | None = None,
                params: ScoreParams = ScoreParams(), give_up_px: float = np.inf,
                refine: RefineParams = RefineParams(), focal_range: float = np.inf) -> Refined:
    """Refine one pose (6,) against the photo's skyline (W,): resection sweep (with
    three matched ``points``), local search, then least squares. When the sweep's best
    score exceeds ``give_up_px`` the candidate is wrong (on the benchmark views right
    ones swept to <= 0.27 px, wrong ones >= 0.7 px) and its best swept pose is returned;
    without points, the same when the local search's first level scores worse (right
    far-horizon candidates 0.39-0.67 px there on view 1, wrong ones 2.75-3.87 on view 5).
    With ``fit_focal`` the last stage fits the focal length too, within ``focal_range`` (a fraction)
    of the candidate's own."""
    f0 = intrinsics.f_px if f_px is None else float(f_px)
    start = np.asarray(pose, np.float64)
    seeds, renders, widest, swept = [start], 0, np.inf, np.nan
    if points is not None and len(points) == 3:
        seeds, swept, spacing, renders = resection_sweep(terrain, start, intrinsics, height, image_skyline, weights,
                                                         f0, points, params=params, refine=refine)
        widest = 2 * spacing
    stages = [np.r_[start[0], start[1], start[3], start[4], start[5], f0, height]]
    if swept > give_up_px:
        stages.append(np.r_[seeds[0][[0, 1, 3, 4, 5]], f0, height])
        return _best_stage(terrain, stages, height, intrinsics, image_skyline, weights, params, renders, seeds[0])
    pose, n, gave_up = local_search(terrain, seeds, intrinsics, height, image_skyline, weights, f0, points=points,
                                    params=params, widest_m=widest,
                                    give_up_px=give_up_px if points is None else np.inf, refine=refine)
    renders += n
    q = np.r_[pose[0], pose[1], pose[3], pose[4], pose[5], f0, height]
    stages.append(q)
    if gave_up:
        return _best_stage(terrain, stages, height, intrinsics, image_skyline, weights, params, renders, pose)
    last = [0, 1, 2, 3, 4] + ([5] if fit_focal else []) + ([6] if refine.fit_height_m > 0 else [])
    for free in ([2, 3, 4], last):
        q, n = _least_squares(terrain, q, free, intrinsics, image_skyline, weights, refine.max_nfev, params,
                              max_height=height + refine.fit_height_m, focal_range=(f0, focal_range))
        stages.append(q)
        renders += n
    return _best_stage(terrain, stages, height, intrinsics, image_skyline, weights, params, renders, pose)


def _best_stage(terrain: Terrain, stages: list[np.ndarray], height: float, intrinsics: Intrinsics,
                image_skyline: np.ndarray, weights: np.ndarray, params: ScoreParams, renders: int,
                fallback: np.ndarray) -> Refined:
    """The best of the refinement's stages (rows x, y, pan, tilt, swing, f, h), the start
    included: a run on a rough score surface can end worse than it began."""
    f0 = stages[0][5]
    poses, k = _pose_of(terrain.dem, np.array(stages), intrinsics)
    inside = np.isfinite(poses[:, 2])
    if not inside.any():
        return Refined(fallback, f0, np.inf, 0.0, renders)
    rendered = render_skylines(terrain, poses[inside], intrinsics, per_pose_intrinsics=k[inside])
    score, agreement = score_skylines(rendered, image_skyline, weights, params)
    j = int(np.argmin(score))
    final = poses[inside][j]
    final[3] %= 360.0
    return Refined(final, float(k[inside][j, 0]), float(score[j]), float(agreement[j]), renders)


def _pose_of(dem, qs: np.ndarray, intrinsics: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Poses (P, 6) and per-pose intrinsics (P, 3) of parameter rows (x, y, pan, tilt, swing, f,
    h = camera height above ground, m)."""
    poses = np.column_stack([camera_centres(dem, qs[:, :2], 0.0), qs[:, 2:5]])
    poses[:, 2] += qs[:, 6]
    return poses, np.column_stack([qs[:, 5], np.full(len(qs), intrinsics.cx), np.full(len(qs), intrinsics.cy)])


def _least_squares(terrain: Terrain, q0: np.ndarray, free: list[int], intrinsics: Intrinsics,
                   image_skyline: np.ndarray, weights: np.ndarray, max_nfev: int,
                   params: ScoreParams, max_height: float = np.inf,
                   focal_range: tuple[float, float] = (1.0, np.inf)) -> tuple[np.ndarray, int]:
    """least_squares over the ``free`` entries of q = (x, y, pan, tilt, swing, f, h); a free
    height h stays within [0, ``max_height``] m, a free focal length within ``focal_range`` = (f,
    fraction): f (1 -+ fraction)."""
    sqrt_w = np.sqrt(np.asarray(weights, np.float64))
    all_steps = np.r_[STEP_XY_M, STEP_XY_M, STEP_DEG, STEP_DEG, STEP_DEG, STEP_F_REL * q0[5], STEP_H_M]
    steps = all_steps[free]
    free_ = np.array(free)
    f_mid, f_frac = focal_range
    lower = np.select([free_ == 6, free_ == 4, free_ == 5], [0.0, -params.max_swing_deg, f_mid * (1 - f_frac)], -np.inf)
    upper = np.select([free_ == 6, free_ == 4, free_ == 5],
                      [max(max_height, q0[6] + 1e-6), params.max_swing_deg, f_mid * (1 + f_frac)], np.inf)
    q0 = q0.copy()
    q0[4] = np.clip(q0[4], -params.max_swing_deg, params.max_swing_deg)  # a start outside the bound moves onto it
    q0[5] = np.clip(q0[5], f_mid * (1 - f_frac), f_mid * (1 + f_frac))
    counter = [0]

    def full(p: np.ndarray) -> np.ndarray:
        qs = np.tile(q0, (len(p), 1))
        qs[:, free] = p
        return qs

    def residuals_of(p: np.ndarray) -> np.ndarray:
        poses, k = _pose_of(terrain.dem, full(p), intrinsics)
        inside = np.isfinite(poses[:, 2])
        out = np.full((len(p), intrinsics.width), -params.cap_px)
        if inside.any():
            counter[0] += int(inside.sum())
            rendered = render_skylines(terrain, poses[inside], intrinsics, tol=FIT_TOL_PX,
                                       per_pose_intrinsics=k[inside])
            e = np.clip(column_errors(rendered, image_skyline, params.cap_px), -params.cap_px, params.cap_px)
            out[inside] = np.where(e < 0, e, params.occluder_weight * e)
        return out * sqrt_w

    cache: dict = {}

    def fun(p):
        key = p.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = residuals_of(p[None])[0]
        return cache[key]

    def jac(p):
        r0 = fun(p)
        rs = residuals_of(p[None] + np.diag(steps))
        return ((rs - r0) / steps[:, None]).T

    result = least_squares(fun, q0[free], jac=jac, loss="soft_l1", f_scale=1.0, x_scale=steps * 5,
                           max_nfev=max_nfev, xtol=1e-6, ftol=1e-6, bounds=(lower, upper))
    return full(result.x[None])[0], counter[0]
