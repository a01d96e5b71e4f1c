"""Stages 3–4 put together: photo skyline -> hypotheses -> poses -> constraints ->
verification -> refinement -> a pose with a confidence, or an abstention.

Two sources of candidates: poses from the model's far horizons
(:mod:`.horizon_search`, verified first) and three-point hypotheses, taken most
probable first in chunks (at most ``max_hypotheses``). After each chunk the best
unrefined candidate of each source by each of the two verification scores
(plain, and far skyline only) is refined; the sources are de-duplicated and
budgeted apart. Once a refined pose scores ``accept_score_px`` and agrees with
the photo's skyline on ``accept_agreement`` of its columns, ``confirm_chunks``
more chunks are tried (a pose tens to hundreds of metres off can fit a far
foreground almost as well) and the best refined pose wins; its confidence falls
when a distinct refined pose fits nearly as well. A search that stops converging
(``stall_chunks`` chunks without a better best score) ends before the budget. With the fov unknown, the
far-horizon search also picks the focal lengths worth refining.

:func:`localize` reads top to bottom as its stages: the image inputs,
:func:`_three_point_hypotheses`, :func:`_far_horizon_candidates`,
:func:`_three_point_rounds` (each chunk through :func:`_screen_chunk`: solver,
constraints, verification; then refinement), the final refinements and
:func:`_decide`; a search about to abstain goes on in :func:`_before_abstaining` (more
far-horizon candidates refined, then every far-horizon pose moved to the best of a grid
around it and the best of those refined) and decides again; with the fov given, an answer still about to be withheld
may ask :func:`_second_opinion` (the photo searched again with the fov unknown, around the given fov where
the fov-unknown search would not come to it; where both end at one place, the answer is given). Real
photographs use :meth:`.params.LocalizeParams.for_photos`: far horizons only, a confidence from the margin to the
runner-up, and the second opinion.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..camera import Intrinsics
from ..errors import InputError
from ..features import ExtractedSkyline, extract_skyline, load_photo, skyline_peaks
from ..features.skyline import SkylineParams
from ..model import Model
from ..render import Terrain, render_skylines
from .confidence import (
    SCORE_REFERENCE_WIDTH_PX,
    agreed_confidence,
    answer_part_margin,
    confidence_of,
    margin_confidence,
    runner_up_index,
    uses_part_margin,
)
from .constraints import in_image_geometry, interfeature_visibility, prior_in_view, segments_in_sky, skyline_limit
from .horizon_search import centre_indices, horizon_poses, standable_centres
from .hypotheses import Hypotheses, generate_hypotheses
from .params import LocalizeParams
from .pose_solver import solve_poses
from .refinement import Refined, local_rescore, refine_pose, weak_axis_sweep
from .result import LocalizationResult, LocalizeStats
from .verification import verify_poses


@dataclass
class _Candidate:
    pose: np.ndarray
    f_px: float
    score: float  # verification scores (px): plain, and counting far skyline only
    trusted: float
    points: np.ndarray | None  # (3, 3) the hypothesis' matched feature points (None: from the horizons)
    refined: Refined | None = None
    ground_slope: float = math.nan  # deg, under the refined pose (DEM.slope_deg)
    # the fov range a far-horizon candidate was found in (1: LocalizeParams.telephoto_fovs; 2: a coarse fov other than
    # the two best-fitting, LocalizeParams.other_fov_refinements)
    lens: int = 0


def standable_mask(slopes, max_slope_deg: float) -> np.ndarray:
    """(K,) bool: which of K poses whose ground slopes ``slopes`` (deg; NaN: off the DEM, kept)
    the answer and its runner-up are chosen among: those at most ``max_slope_deg``; all of them
    where none is, or where the bound is infinite (``LocalizeParams.max_answer_slope_deg``)."""
    slopes = np.asarray(slopes, np.float64)
    keep = ~(slopes > max_slope_deg)
    return keep if keep.any() else np.ones(len(slopes), bool)


def column_weights(confidence: np.ndarray, power: float = 1.0) -> np.ndarray:
    """(W,) weights of the skyline's columns in every match (far-horizon search,
    verification, refinement): the extractor's per-column confidence, at least 0.05, raised
    to ``power`` (a higher power discounts doubtful columns more)."""
    return np.clip(np.asarray(confidence, np.float64), 0.05, 1.0) ** power


def _image_skyline(image, skyline, extractor: SkylineParams, power: float = 1.0) -> tuple[np.ndarray, np.ndarray, int, int]:
    """(skyline, weights, W, H) from a photo (path or array) or a given skyline; ``extractor``:
    the extractor's parameters when none is given; ``power``: of the confidence in the
    column weights (:func:`column_weights`)."""
    if isinstance(image, (str, bytes)) or hasattr(image, "__fspath__"):
        image = load_photo(image)
    image = np.asarray(image)
    if image.ndim < 2:
        raise InputError(f"an image must be 2-D (H x W) or H x W x channels, got shape {image.shape}")
    H, W = image.shape[:2]
    if skyline is None:
        skyline = extract_skyline(image, extractor)
    if isinstance(skyline, ExtractedSkyline):
        return skyline.skyline.astype(np.float64), column_weights(skyline.confidence, power), W, H
    sky = np.asarray(skyline, np.float64)
    if sky.shape != (W,):
        raise InputError(f"the skyline has {sky.size} values but the image is {W} columns wide")
    return sky, np.ones(W), W, H


def image_peaks(sky: np.ndarray, params: LocalizeParams) -> list:
    """The skyline peaks that generate hypotheses: the ``n_peaks`` largest on a
    ``peak_smooth_px`` smoothed skyline, steep foreground bumps left out."""
    return skyline_peaks(sky, n=params.n_peaks, smooth_px=params.peak_smooth_px, max_aspect=params.max_peak_aspect)


def _distinct(poses: list[np.ndarray], pose: np.ndarray, same_m: float) -> bool:
    """True when ``pose`` is farther than ``same_m`` (m) or 3 deg of pan from each of ``poses``."""
    for other in poses:
        if math.hypot(other[0] - pose[0], other[1] - pose[1]) < same_m and abs(
                (other[3] - pose[3] + 180.0) % 360.0 - 180.0) < 3.0:
            return False
    return True


def _take_distinct(poses: np.ndarray, order, taken: list[np.ndarray], same_m: float,
                   limit: int | None = None) -> list[int]:
    """Indices of ``poses``, walked in ``order``, distinct (:func:`_distinct`) from ``taken`` and
    from each other, at most ``limit``; each taken pose is appended to ``taken``."""
    picked = []
    for j in order:
        if limit is not None and len(picked) == limit:
            break
        if _distinct(taken, poses[j], same_m):
            taken.append(poses[j])
            picked.append(int(j))
    return picked


@dataclass
class _Search:
    """What every stage of one localization reads: the photo's skyline and peaks, the
    model and terrain, the fovs tried, the prior's features, the parameters and stats;
    and what they build up: the candidates."""

    model: Model
    terrain: Terrain
    height: float
    fov: float | None  # given (None: unknown)
    fovs: tuple  # tried
    sky: np.ndarray
    weights: np.ndarray
    width: int
    img_height: int
    peak_uv: np.ndarray
    in_sky: np.ndarray
    in_view: np.ndarray | None
    params: LocalizeParams
    stats: LocalizeStats
    curvature: bool
    candidates: list = field(default_factory=list)
    # the first chunks' verified three-point poses, for the weak-axis sweep: (poses, points, image peaks, fov)
    swept_pool: list = field(default_factory=list)
    # the far-horizon poses of the fovs whose best joined the candidates, for the rescore before abstaining:
    # (f_px, fov, poses)
    horizon_pool: list = field(default_factory=list)
    solver: object = solve_poses  # solve_poses, or a skyrender.scale.SplitSolver spreading it over a cluster

    def intrinsics(self, fov: float) -> Intrinsics:
        return Intrinsics.from_fov(fov, self.width, self.img_height)

    @property
    def fit_focal(self) -> bool:
        return self.fov is None or self.params.refine_fov


def localize(image, model: Model, height: float, fov: float | None = None, prior=None, *,
             terrain: Terrain | None = None, skyline=None, params: LocalizeParams = LocalizeParams(),
             curvature: bool = True, solver=None) -> LocalizationResult:
    """Camera pose from one photograph and a model.

    Parameters
    ----------
    image : photo path or array (H x W [x C]).
    model : the model databases of the DEM (:func:`skyrender.model.build_model`).
    height : camera height above ground (m).
    fov : horizontal field of view (degrees); None = unknown, estimated.
    prior : None, or a dict for :meth:`Model.features_for_prior` ("mountain X visible":
        ``{"ids": [...]}``, or "a peak within radius of (x, y) is visible":
        ``{"x": .., "y": .., "radius": ..}``). A pose must show one of those peaks
        in its image; hypotheses built on them are tried first.
    terrain : a Terrain of ``model.dem`` to reuse; skyline : the photo's skyline
        (an ExtractedSkyline or a (W,) array) when already extracted.
    solver : the three-point solver (default :func:`solve_poses`); a
        :class:`skyrender.scale.SplitSolver` spreads the hypothesis search over a Dask
        cluster (same poses; it pays only where workers have cores of their own).

    Returns a :class:`LocalizationResult` (``status`` "localized" or "abstained").
    """
    if not (math.isfinite(height) and height >= 0):
        raise InputError(f"camera height above ground must be >= 0 m, got {height}")
    t_start = time.perf_counter()
    stats = LocalizeStats()
    with stats.timed("image_features"):
        photo_sky, photo_weights, photo_W, photo_H = _image_skyline(image, skyline, params.skyline_params(),
                                                                    params.confidence_power)
    with stats.timed("terrain"):
        terrain = terrain if terrain is not None else Terrain(model.dem, curvature=curvature)
    photo = (photo_sky, photo_weights, photo_W, photo_H)
    search, accepted, result = _search_and_decide(photo, model, terrain, height, fov, prior, params, stats, curvature,
                                                  solver or solve_poses, t_start)
    if _wants_second_opinion(search, result):
        with stats.timed("second_opinion"):
            result = _second_opinion(search, accepted, result, photo, prior, t_start)
    if search.width != photo_W:
        result = _in_photo_pixels(result, terrain, photo_sky, photo_W, photo_H, search.width)
    return result


def _search_and_decide(photo: tuple, model: Model, terrain: Terrain, height: float, fov: float | None, prior,
                       params: "LocalizeParams", stats: LocalizeStats, curvature: bool, solver,
                       t_start: float) -> tuple["_Search", "_Candidate | None", LocalizationResult]:
    """Stages 3-4d for a photo's skyline ``photo`` = (skyline, column weights, W, H): the search, its
    refinements and its answer or abstention (in the searched pixels, :func:`reduce_skyline`)."""
    photo_sky, photo_weights, photo_W, photo_H = photo
    with stats.timed("image_features"):
        sky, weights, W, H = photo_sky, photo_weights, photo_W, photo_H
        if params.search_width is not None and photo_W > params.search_width:
            sky, weights, W, H = reduce_skyline(photo_sky, photo_weights, photo_W, photo_H, params.search_width)
        stats.searched_width = W
        peaks = image_peaks(sky, params)
    peak_uv = np.array([[p.u, p.v] for p in peaks]).reshape(-1, 2)
    fovs = (float(fov),) if fov is not None else tuple(params.fov_candidates)
    in_view = model.features_for_prior(**prior) if prior else None
    search = _Search(model, terrain, height, fov, fovs, sky, weights, W, H, peak_uv, segments_in_sky(peak_uv, sky), in_view,
                     params, stats, curvature, solver=solver)
    with stats.timed("hypotheses"):
        hyps = _three_point_hypotheses(search, np.array([p.size for p in peaks]))
    if params.use_horizons and len(model.horizons):
        _far_horizon_candidates(search)
    accepted = _three_point_rounds(search, hyps)
    if accepted is None and search.swept_pool:
        with stats.timed("weak_sweep"):
            _weak_axis_candidates(search)
    with stats.timed("refinement"):
        final = params.final_refinements if accepted is None else 0
        for cand in _next_to_refine(search.candidates, final, params, budgeted=False):
            _refine(cand, search)
    result = _decide(search, accepted, t_start)
    if not result.localized:
        result = _before_abstaining(search, accepted, t_start, result)
    return search, accepted, result


def _wants_second_opinion(search: "_Search", result: LocalizationResult) -> bool:
    """Whether a fov-given search about to abstain asks a second search, with the fov unknown
    (:func:`_second_opinion`): its confidence fell short, but not below ``second_opinion_from``."""
    return (search.fov is not None and not result.localized and bool(search.candidates)
            and result.confidence >= search.params.second_opinion_from)


def _second_opinion(search: "_Search", accepted: "_Candidate | None", result: LocalizationResult, photo: tuple,
                    prior, t_start: float) -> LocalizationResult:
    """Stage 4e: the photo searched again with the fov unknown (same skyline, terrain and parameters). A look-alike
    fits the skyline at the given focal length; at a focal length of its own the search finds another. So where both
    searches' best places lie within ``second_opinion_m`` of each other, the logit of the fov-given answer's
    confidence gains ``second_opinion_gain`` (:func:`.confidence.agreed_confidence`; fitted on the training photos by
    ``localize_fit``), and the answer is given if that reaches the threshold; otherwise the abstention stands.
    The second search's best place and the distance are kept in the stats."""
    params, stats = search.params, search.stats
    best, _ = _best_refined(search, accepted)  # the answer _decide withheld (its confidence is the result's)
    other = LocalizeStats()
    second, second_accepted, _ = _search_and_decide(photo, search.model, search.terrain, search.height, None, prior,
                                                    second_opinion_params(params, search.fov), other, search.curvature,
                                                    search.solver, time.perf_counter())
    second_best, _ = _best_refined(second, second_accepted)
    withheld = replace(result, seconds=time.perf_counter() - t_start)  # the second search's time counted
    if best is None or second_best is None:
        return withheld
    apart = float(np.hypot(*(np.asarray(best.refined.pose[:2]) - np.asarray(second_best.refined.pose[:2]))))
    stats.second_opinion = {"pose": [float(v) for v in (*second_best.refined.pose, second_best.refined.f_px,
                                                         second_best.refined.score)],
                            "apart_m": apart, "seconds": round(sum(other.seconds.values()), 4)}
    if apart > params.second_opinion_m:
        return withheld
    confidence = agreed_confidence(result.confidence, params.second_opinion_gain)
    if confidence < params.abstain_below(False):
        return replace(withheld, confidence=confidence)
    return _localized(search, best, confidence, t_start)


def fov_within_reach(params: LocalizeParams, fov: float) -> bool:
    """Whether the search with the fov unknown (``params.fov_candidates``, then ``params.horizon_fov_step`` around
    the best: probes in degrees) can come to the horizontal fov ``fov`` (deg): from the smallest coarse fov less
    every step to the largest plus them (the photo preset's 27.5-72.5 deg)."""
    fovs, reach = tuple(params.fov_candidates), float(sum(params.horizon_fov_step))
    return min(fovs) - reach <= fov <= max(fovs) + reach


def second_opinion_params(params: LocalizeParams, fov: float) -> LocalizeParams:
    """The parameters of the second opinion's search (:func:`_second_opinion`, the fov unknown) for a photo whose
    horizontal fov ``fov`` (deg) was given: ``params`` where that search reaches it (:func:`fov_within_reach`);
    else its coarse fovs and probe steps scaled by ``fov`` over the middle coarse fov, so that it spans the given
    fov as it spans the middle one. A search that never comes to the photo's fov cannot agree with its answer: the
    photo preset's 35 / 50 / 65 deg never come below 27.5 deg, and a third of CH1's validation photos are
    10.6-28 deg wide (a 19.5-deg photo is searched at 13.65 / 19.5 / 25.35 deg, probes 1.95 and 0.975 deg)."""
    if fov_within_reach(params, fov):
        return params
    scale = fov / sorted(params.fov_candidates)[len(params.fov_candidates) // 2]
    return replace(params, fov_candidates=tuple(f * scale for f in params.fov_candidates),
                   horizon_fov_step=tuple(s * scale for s in params.horizon_fov_step))


def reduce_skyline(sky: np.ndarray, weights: np.ndarray, W: int, H: int,
                   width: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """A photo's skyline (W,) (rows, NaN: no terrain in the column) and column weights as the same photo
    ``width`` px wide would have them: (skyline, weights, width, height). Each reduced column is
    read at its centre's place on the photo's columns (linearly between the two nearest, the nearer
    one's value where either is NaN), its row scaled by height / H; height = round(H width / W). Pixel
    centres lie at +0.5 (as :func:`~skyrender.camera.pixel_directions` has them), so a pose seen with
    the fov on the photo sees the same directions on the reduced one."""
    scale = W / width
    height = max(2, int(round(H / scale)))
    u = np.clip((np.arange(width) + 0.5) * scale - 0.5, 0.0, W - 1.0)
    left = np.floor(u).astype(np.int64)
    right = np.minimum(left + 1, W - 1)
    t = u - left
    nearer = np.where(t < 0.5, left, right)
    sky = np.asarray(sky, np.float64)
    between = (1.0 - t) * sky[left] + t * sky[right]
    rows = np.where(np.isfinite(between), between, sky[nearer]) * (height / H)
    w = np.asarray(weights, np.float64)
    return rows, (1.0 - t) * w[left] + t * w[right], width, height


def _in_photo_pixels(result: LocalizationResult, terrain: Terrain, sky: np.ndarray, W: int, H: int,
                     searched_width: int) -> LocalizationResult:
    """A result searched on a reduced skyline (:func:`reduce_skyline`) in the photo's own pixels: its
    intrinsics (the same fov), the photo's skyline, the answer's skyline rendered at the photo's size,
    and the refined poses' and the second opinion's focal lengths (stats)."""
    scale = W / searched_width
    result.stats.refined_poses = [(*r[:6], r[6] * scale, r[7]) for r in result.stats.refined_poses]
    if result.stats.second_opinion is not None:
        pose = result.stats.second_opinion["pose"]
        result.stats.second_opinion["pose"] = [*pose[:6], pose[6] * scale, pose[7]]
    fov = result.fov if result.localized else result.intrinsics.fov
    k = Intrinsics.from_fov(fov, W, H)
    rendered = render_skylines(terrain, result.pose, k) if result.localized else None
    return replace(result, intrinsics=k, image_skyline=sky, rendered_skyline=rendered)


def _before_abstaining(search: _Search, accepted: _Candidate | None, t_start: float,
                       result: LocalizationResult) -> LocalizationResult:
    """Stage 4d, for a search about to abstain: more candidates refined in two rounds, the answer
    decided again after each. First the best far-horizon candidates left unrefined
    (``escalate_refinements`` by each ranking); then, if it still abstains, the best far-horizon
    poses once moved to the best of a grid around them (``rescore_refinements``)."""
    params, stats = search.params, search.stats
    if params.escalate_refinements > 0:
        with stats.timed("escalation"):
            horizon = [c for c in search.candidates if c.points is None and c.refined is None]
            escalated = _best_by_either(horizon, params.escalate_refinements)
            for cand in escalated:
                _refine(cand, search)
        if escalated:
            result = _decide(search, accepted, t_start)
    if result.localized or params.rescore_refinements <= 0 or not search.horizon_pool:
        return result
    with stats.timed("rescore"):
        rescored = _rescored_horizon_candidates(search)
        for cand in rescored:
            _refine(cand, search)
    return _decide(search, accepted, t_start) if rescored else result


def _rescored_horizon_candidates(search: _Search) -> list[_Candidate]:
    """Every kept far-horizon pose moved to the best of a ``rescore_grid``² grid ±``rescore_half_m``
    around it (:func:`local_rescore`, every ``rescore_stride``-th column); the best
    ``rescore_refinements`` of each fov's, distinct from the poses refined so far and from each
    other, join the candidates (and are returned)."""
    params = search.params
    taken = [c.refined.pose for c in search.candidates if c.refined is not None]
    added = []
    for f_px, fov_i, poses in search.horizon_pool:
        moved, score = local_rescore(search.terrain, poses, search.intrinsics(fov_i), search.height, search.sky,
                                     search.weights, params.rescore_half_m, params.rescore_grid, params.rescore_stride,
                                     params.score)
        search.stats.verified += len(poses) * params.rescore_grid ** 2
        order = np.argsort(score, kind="stable")
        order = order[np.isfinite(score[order])]
        for j in _take_distinct(moved, order, taken, params.same_pose_m, params.rescore_refinements):
            added.append(_Candidate(moved[j], f_px, float(score[j]), float(score[j]), None))
    search.candidates.extend(added)
    return added


def _three_point_hypotheses(search: _Search, peak_sizes: np.ndarray) -> Hypotheses:
    """Stage 3a: (image triple, model triple) hypotheses, most probable first, at most
    ``max_hypotheses``; none when the photo has fewer than three peaks."""
    params = search.params
    hyps = Hypotheses(np.zeros((0, 3), np.int64), np.zeros((0, 3), np.int64), np.zeros(0))
    if len(search.peak_uv) >= 3 and params.max_hypotheses > 0:
        hyps = generate_hypotheses(search.peak_uv[:, 0], peak_sizes, search.model, search.in_view, params.ordered,
                                   neighbours=params.neighbours, k=params.neighbours_k, prior_boost=params.prior_boost,
                                   limit=params.max_hypotheses)
    search.stats.generated = len(hyps) * len(search.fovs)
    return hyps


def _far_horizon_candidates(search: _Search) -> None:
    """Stage 3c: poses from the far-horizon search at each fov tried (bisected around the
    best when the fov is unknown: those probes search only the horizon centres found at the
    fovs before, ``LocalizeParams.fov_probes_on_found``), verified; the best of the
    best-fitting fov (two fovs when unknown) join the candidates. With the fov unknown and
    ``telephoto_fovs`` given, the telephoto range is searched and bisected the same way apart,
    and the best of its two best-fitting fovs join the candidates as lens range 1 (refined on a
    budget of their own: before refinement a wrong place fits a narrow view better than the
    right place a wide one, experiments/ch1/fov-unknown-range/)."""
    params, stats, features = search.params, search.stats, search.model.features.xyz

    def verify_at(verified: dict, fov_i: float, centres: np.ndarray | None = None) -> float:
        """Far-horizon poses at one fov (from ``centres`` only, when given), verified into ``verified``
        (fov -> (f_px, poses, plain score, second ranking)); returns their best plain score (px)."""
        k_i = search.intrinsics(fov_i)
        with stats.timed("horizon_search"):
            poses, cost = horizon_poses(search.model.horizons, search.sky, search.weights, k_i, search.model.dem,
                                        search.height, params.horizon, centres=centres)
            if search.in_view is not None and len(poses):
                seen = prior_in_view(poses, features[search.in_view], search.sky, k_i, params.limit_tol_px,
                                     search.curvature)
                poses, cost = poses[seen], cost[seen]
            stats.generated += len(poses)
        with stats.timed("verification"):
            score, trusted = verify_poses(search.terrain, poses, k_i, search.sky, search.weights, params.verify_stride,
                                          params=params.score)
            if params.horizon.rank_by_cost:  # the second ranking: the search's own cost
                trusted = cost
            stats.verified += len(poses)
            stats.horizon_poses += len(poses)
        verified[fov_i] = (k_i.f_px, poses, score, trusted)
        return _best_of(score)

    standable = standable_centres(search.model.horizons, search.model.dem, params.max_ground_slope_deg)
    ranges = [(search.fovs, params.horizon_fov_step, False)]
    if search.fov is None and params.telephoto_fovs:
        ranges.append((tuple(params.telephoto_fovs), params.telephoto_fov_step, True))
    for lens, (fovs, steps, ratio) in enumerate(ranges):
        verified = {}
        for fov_i in fovs:
            verify_at(verified, fov_i, standable)
        if search.fov is None:
            def probe(fov_i: float, verified=verified) -> float:
                if not params.fov_probes_on_found:
                    return verify_at(verified, fov_i)
                # the place is found at the coarse fovs; a probe only picks the fov
                xy = np.concatenate([v[1][:, :2] for v in verified.values()])
                found = centre_indices(search.model.horizons, xy)
                return verify_at(verified, fov_i, found[found >= 0])
            _narrow_fov(verified, probe, steps, ratio)
        # a wrong focal length scales the skyline's azimuths: the best fits pick the fov
        best_fovs = sorted(verified, key=lambda f: _best_of(verified[f][2]))[: 1 if search.fov is not None else 2]
        for fov_i in best_fovs:
            f_px, poses, score, trusted = verified[fov_i]
            if params.horizon_rerank and (search.fov is not None or params.rerank_fov_unknown):
                with stats.timed("rerank"):
                    poses, score, trusted = _rerank(search, poses, score, trusted, fov_i)
            _add_candidates(search.candidates, poses, score, trusted, f_px, None, params, lens)
            search.horizon_pool.append((f_px, fov_i, poses))
        if search.fov is None and lens == 0 and params.other_fov_refinements:
            for fov_i in [f for f in fovs if f not in best_fovs]:
                f_px, poses, score, trusted = verified[fov_i]
                _add_candidates(search.candidates, poses, score, trusted, f_px, None, params, lens=2)


def _rerank(search: _Search, poses: np.ndarray, score: np.ndarray, second: np.ndarray,
            fov_i: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`rerank_far_horizon` of the far-horizon poses at one fov: the moved poses, their
    new scores (the first ranking from now on) and their second ranking; the rest left out."""
    params = search.params
    if search.fov is None and params.horizon_rerank_fov_unknown is not None:
        params = replace(params, horizon_rerank=params.horizon_rerank_fov_unknown)
    pick, moved, rescored = rerank_far_horizon(search.terrain, poses, score, second, search.intrinsics(fov_i),
                                               search.height, search.sky, search.weights, params)
    search.stats.verified += len(pick) * params.rerank_grid ** 2
    return moved, rescored, second[pick]


def rerank_far_horizon(terrain, poses: np.ndarray, score: np.ndarray, second: np.ndarray, intrinsics, height: float,
                       sky: np.ndarray, weights: np.ndarray, params: LocalizeParams):
    """The best ``params.horizon_rerank`` poses by each ranking (``score``, ``second``), each moved
    to the best of a grid around it (:func:`local_rescore`): (their indices, moved poses, scores)."""
    k = params.horizon_rerank
    pick = np.unique(np.r_[np.argsort(score, kind="stable")[:k], np.argsort(second, kind="stable")[:k]])
    moved, rescored = local_rescore(terrain, poses[pick], intrinsics, height, sky, weights, params.rerank_half_m,
                                    params.rerank_grid, rerank_columns(params, intrinsics.width), params.score)
    return pick, moved, rescored


def rerank_columns(params: LocalizeParams, width_px: int) -> int:
    """The re-ranking's column stride on a photo ``width_px`` wide: ``params.rerank_stride`` scaled from
    :data:`SCORE_REFERENCE_WIDTH_PX` (at least 1), or ``params.verify_stride`` where that is None."""
    if params.rerank_stride is None:
        return params.verify_stride
    return max(1, int(round(params.rerank_stride * width_px / SCORE_REFERENCE_WIDTH_PX)))


def _screen_chunk(search: _Search, chunk: Hypotheses, fov_i: float, keep_for_sweep: bool = False) -> None:
    """Stages 3b-4a for one chunk of hypotheses at one fov: solve the poses, prune them
    by residual, geometry, prior, "skyline is the limit" and inter-feature visibility,
    verify the survivors and add the best as candidates (and, ``keep_for_sweep``, keep
    every verified one for :func:`_weak_axis_candidates`)."""
    params, stats, features = search.params, search.stats, search.model.features.xyz
    k_i = search.intrinsics(fov_i)
    with stats.timed("pose_solver"):
        poses, residual = search.solver(search.model.dem, search.peak_uv[chunk.image], features[chunk.features],
                                      search.height, k_i.f_px, k_i.cx, k_i.cy, search.curvature,
                                      gn_iterations=params.gn_iterations)
        stats.evaluated += len(chunk)
    with stats.timed("constraints"):
        keep = residual <= params.residual_px
        stats.rejected["residual"] += int((~keep).sum())
        idx = np.flatnonzero(keep)
        idx = _apply(idx, in_image_geometry(poses[idx], features[chunk.features[idx]], k_i, search.curvature), stats,
                     "geometry")
        if search.in_view is not None:
            idx = _apply(idx, prior_in_view(poses[idx], features[search.in_view], search.sky, k_i, params.limit_tol_px,
                                            search.curvature), stats, "prior")
        idx = _apply(idx, skyline_limit(poses[idx], features, search.sky, k_i, params.limit_tol_px,
                                        curvature=search.curvature), stats, "skyline_limit")
    with stats.timed("visibility"):
        idx = _apply(idx, interfeature_visibility(search.terrain, chunk.image[idx], chunk.features[idx], features,
                                                  search.in_sky), stats, "interfeature_visibility")
    if len(idx) == 0:
        return
    with stats.timed("verification"):
        kept = idx[_dedupe(poses[idx])]
        score, trusted = verify_poses(search.terrain, poses[kept], k_i, search.sky, search.weights,
                                      params.verify_stride, params=params.score)
        stats.verified += len(kept)
        _add_candidates(search.candidates, poses[kept], score, trusted, k_i.f_px, features[chunk.features[kept]],
                        params)
    if keep_for_sweep:
        search.swept_pool.append((poses[kept], features[chunk.features[kept]], search.peak_uv[chunk.image[kept]], fov_i))


def _weak_axis_candidates(search: _Search) -> None:
    """Stage 4a again, for a search about to abstain: the first chunks' weakly held
    three-point poses moved along their weak axis (:func:`weak_axis_sweep`) join the
    candidates, so the final refinements see them."""
    params = search.params
    share = replace(params.weak_sweep, max_positions=params.weak_sweep.max_positions // len(search.swept_pool))
    for poses, points, image_uv, fov_i in search.swept_pool:
        k_i = search.intrinsics(fov_i)
        swept, moved, score, trusted = weak_axis_sweep(search.terrain, poses, points, image_uv, k_i, search.height,
                                                       search.sky, search.weights, share, params.score)
        search.stats.verified += len(swept)
        _add_candidates(search.candidates, moved, score, trusted, k_i.f_px, points[swept], params)


def _three_point_rounds(search: _Search, hyps: Hypotheses) -> _Candidate | None:
    """Hypotheses in chunks; after each, the best unrefined candidates are refined. Once
    one is accepted (score and agreement), ``confirm_chunks`` more chunks are tried.
    Returns the accepted candidate, or None."""
    params = search.params
    accepted, stop_after = None, len(hyps)
    # the stop rule assumes the most probable hypotheses come first: not with a seeded arbitrary order, nor with a
    # prior (its boosted triples first, then the rest: with one, bench-localize's view 5 was found in the 23rd chunk,
    # after 22 with no better score)
    stall_chunks = params.stall_chunks if params.ordered and search.in_view is None else 0
    for start in range(0, len(hyps), params.chunk):
        if start >= stop_after or (accepted is None and search_stalled(search.stats.rounds, stall_chunks,
                                                                       params.stall_gain)):
            break
        chunk = hyps.take(slice(start, start + params.chunk))
        for fov_i in search.fovs:
            _screen_chunk(search, chunk, fov_i, keep_for_sweep=start < params.weak_sweep.chunks * params.chunk)
        search.candidates = [c for from_peaks in (True, False) for c in _best_by_either(
            [c for c in search.candidates if (c.points is not None) == from_peaks], 8 * params.final_refinements)]
        with search.stats.timed("refinement"):
            # the three-point candidates first; once a pose is accepted (in this chunk or before), no far-horizon
            # one: the answer is the accepted pose, and the far-horizon candidates are the same in every chunk
            for cand in _next_to_refine(search.candidates, params.refine_per_chunk, params, horizons=False):
                _refine(cand, search)
            accepted = _accepted(search) or accepted
            if accepted is None:
                for cand in _next_to_refine(search.candidates, params.refine_per_chunk, params, peaks=False):
                    _refine(cand, search)
                accepted = _accepted(search)
        if accepted is not None:
            stop_after = min(stop_after, start + (1 + params.confirm_chunks) * params.chunk)
        search.stats.rounds.append(_round_record(search, accepted is not None))
    return accepted


def _accepted(search: _Search) -> _Candidate | None:
    """The best refined candidate that scores ``accept_score_px`` or better and agrees on
    ``accept_agreement`` of the columns, if any."""
    params = search.params
    good = [c for c in search.candidates if c.refined is not None and c.refined.score <= params.accept_score_px
            and c.refined.agreement >= params.accept_agreement]
    return min(good, key=lambda c: c.refined.score) if good else None


def search_stalled(rounds: list[dict], stall_chunks: int, stall_gain: float) -> bool:
    """The stop rule on the search's trace so far (``LocalizeStats.rounds``): True when the
    last ``stall_chunks`` chunks bettered none of the best verified, trusted and refined
    three-point scores by more than ``stall_gain`` (a share) — the search is not converging.
    On 26 rendered views (16 whole-tile, 10 of bench-localize; ``python -m
    skyrender.diagnostics.search_rounds``) right answers came at most 6 chunks after the
    last 5 % gain, but a 20 %-occluded view (a test) only after 17 chunks of gains under 2 %."""
    if stall_chunks <= 0 or len(rounds) <= stall_chunks:
        return False
    then, now = rounds[-1 - stall_chunks], rounds[-1]
    for key in ("best_verified", "best_trusted", "best_refined"):
        if then[key] is None or (now[key] is not None and now[key] < (1.0 - stall_gain) * then[key]):
            return False
    return True


def _round_record(search: _Search, accepted: bool) -> dict:
    """One entry of ``stats.rounds``: after a chunk, the hypotheses solved and the best
    three-point candidates' verified and refined scores (px) so far."""
    mine = [c for c in search.candidates if c.points is not None]
    refined = [c.refined.score for c in mine if c.refined is not None]
    return {"evaluated": search.stats.evaluated, "best_verified": min((c.score for c in mine), default=None),
            "best_trusted": min((c.trusted for c in mine), default=None),
            "best_refined": min(refined, default=None), "refined": len(refined), "accepted": accepted}


def _decide(search: _Search, accepted: _Candidate | None, t_start: float) -> LocalizationResult:
    """Stage 4c: the best refined pose (the accepted one if any) with its confidence
    against the runner-up, or an abstention below ``min_confidence``."""
    params, stats = search.params, search.stats
    best, confidence = _answer(search, accepted)
    if best is None or confidence < params.abstain_below(search.fov is None):
        # an abstention keeps the confidence it fell short with (0 when nothing was refined)
        return LocalizationResult("abstained", None, None, confidence, time.perf_counter() - t_start, stats.evaluated,
                                  stats, search.intrinsics(search.fovs[0]), search.sky)
    return _localized(search, best, confidence, t_start)


def _answer(search: _Search, accepted: _Candidate | None) -> tuple[_Candidate | None, float]:
    """The answer a search would give, abstaining or not: the best refined candidate (the accepted
    one if any; among poses on standable ground, ``max_answer_slope_deg``) and its confidence against
    the runner-up (0 when nothing was refined); the best and runner-up scores go to the stats."""
    params, stats = search.params, search.stats
    W, H = search.width, search.img_height
    best, done = _best_refined(search, accepted)
    if best is None:
        return None, 0.0
    if params.runner_up_m is None:
        others = [c for c in done if c is not best and _distinct([best.refined.pose], c.refined.pose,
                                                                 params.same_pose_m)]
    else:
        i = runner_up_index([c.refined.pose[:2] for c in done], [c.refined.score for c in done],
                            [c is best for c in done].index(True), params.runner_up_m)
        others = [] if i is None else [done[i]]
    runner_up = others[0].refined if others else None
    stats.best_score, stats.runner_up_score = best.refined.score, runner_up.score if runner_up else None
    if params.confidence_model != "margin":
        return best, confidence_of(best.refined, runner_up)
    part = 0.0
    if uses_part_margin(params.margin_logit) and best is not accepted:
        refined = np.array([(*c.refined.pose, c.refined.f_px, c.refined.score) for c in done])
        with stats.timed("part_margin"):
            part = answer_part_margin(search.terrain, refined, search.sky, search.weights, H,
                                      params.places_apart_m, params.score)
        stats.part_margin = part
    return best, margin_confidence(best.refined.score, runner_up.score if runner_up else np.inf,
                                   params.margin_logit, W, part)


def _best_refined(search: _Search, accepted: _Candidate | None) -> tuple[_Candidate | None, list[_Candidate]]:
    """The answer's candidate (the accepted one if any, else the best refined; None when nothing was refined) and
    the refined candidates it is chosen among, best first (on standable ground, ``max_answer_slope_deg``)."""
    done = sorted([c for c in search.candidates if c.refined is not None], key=lambda c: c.refined.score)
    if accepted is None and done:
        keep = standable_mask([c.ground_slope for c in done], search.params.max_answer_slope_deg)
        done = [c for c, k in zip(done, keep) if k]
    return accepted or (done[0] if done else None), done


def _localized(search: _Search, best: _Candidate, confidence: float, t_start: float) -> LocalizationResult:
    """The answer ``best`` given with ``confidence``: its pose, fov, the photo's and its rendered skyline."""
    model = search.model
    W, H = search.width, search.img_height
    r = best.refined
    k_best = Intrinsics(W, H, r.f_px, W / 2.0, H / 2.0)
    rendered = render_skylines(search.terrain, r.pose, k_best)
    lonlat = None
    if model.dem.crs is not None:
        lon, lat = model.dem.to_lonlat(r.pose[0], r.pose[1])
        lonlat = (float(lon), float(lat))
    return LocalizationResult("localized", r.pose, k_best.fov, confidence, time.perf_counter() - t_start,
                              search.stats.evaluated, search.stats, k_best, search.sky, rendered, model.dem.crs, lonlat)


def _best_of(score: np.ndarray) -> float:
    return float(score.min()) if len(score) else np.inf


def _narrow_fov(verified: dict, verify_at, steps: tuple[float, ...], ratio: bool = False) -> None:
    """Unknown fov: bisect around the best-fitting fov so far (by the far-horizon poses'
    best verification score), one probe on each side per step: ``best -+ step`` (deg) within
    the fovs tried, or with ``ratio`` ``best / (1 + step)`` and ``best * (1 + step)`` within
    the fovs tried widened by the first step's ratio."""
    lo, hi = min(verified), max(verified)
    if ratio and steps:
        lo, hi = lo / (1.0 + steps[0]), hi * (1.0 + steps[0])
    for step in steps:
        best = min(verified, key=lambda f: _best_of(verified[f][2]))
        probes = (best / (1.0 + step), best * (1.0 + step)) if ratio else (best - step, best + step)
        for f in probes:
            if lo <= f <= hi and f not in verified:
                verify_at(f)


def _add_candidates(candidates: list[_Candidate], poses: np.ndarray, score: np.ndarray, trusted: np.ndarray,
                    f_px: float, points: np.ndarray | None, params: LocalizeParams, lens: int = 0) -> None:
    """Append the best verified poses by each score (distinct from those already kept);
    ``points`` (P, 3, 3): each pose's matched feature points, None for horizon poses; ``lens``:
    the fov range searched (0, or 1 for the telephoto range)."""
    n = 4 * params.final_refinements
    best = np.unique(np.r_[np.argsort(score)[:n], np.argsort(trusted)[:n]]).astype(np.int64)
    kept = [c.pose for c in candidates if (c.points is None) == (points is None)]  # each source apart
    for j in _take_distinct(poses, best[np.argsort(score[best])], kept, params.same_pose_m):
        candidates.append(_Candidate(poses[j], f_px, float(score[j]), float(trusted[j]),
                                     None if points is None else points[j], lens=lens))


def _best_by_either(candidates: list[_Candidate], n: int) -> list[_Candidate]:
    """The ``n`` best candidates by plain score and the ``n`` best by trusted score (up
    to 2n, in plain-score order): each ranking finds right candidates the other misses."""
    keep = {id(c): c for key in ("score", "trusted") for c in sorted(candidates, key=lambda c: getattr(c, key))[:n]}
    return sorted(keep.values(), key=lambda c: c.score)


def _next_to_refine(candidates: list[_Candidate], n: int, params: LocalizeParams,
                    budgeted: bool = True, horizons: bool = True, peaks: bool = True) -> list[_Candidate]:
    """:func:`_best_by_either` among the candidates not refined yet, up to ``n`` of the
    three-point (with ``peaks``) and ``n`` of the far-horizon ones (with ``horizons``; of those
    from the telephoto range, ``telephoto_refinements`` apart, and of those from the other coarse fovs,
    ``other_fov_refinements``), within each one's refinement budget when ``budgeted``."""
    picked = []
    sources = ((True, 0, n, params.max_refinements), (False, 0, n, params.max_horizon_refinements),
               (False, 1, min(n, params.telephoto_refinements), params.telephoto_refinements),
               (False, 2, min(n, params.other_fov_refinements), params.other_fov_refinements))
    for from_peaks, lens, most, limit in [s for s in sources if (peaks if s[0] else horizons)]:
        mine = [c for c in candidates if (c.points is not None) == from_peaks and c.lens == lens]
        budget = max(0, min(most, limit - sum(c.refined is not None for c in mine))) if budgeted else most
        picked += _best_by_either([c for c in mine if c.refined is None], budget)
    return picked


def _apply(idx: np.ndarray, ok: np.ndarray, stats: LocalizeStats, name: str) -> np.ndarray:
    stats.rejected[name] += int((~ok).sum())
    return idx[ok]


def _dedupe(poses: np.ndarray, cell_m: float = 50.0, cell_deg: float = 1.0) -> np.ndarray:
    """Indices of one pose per (x, y, pan) bin: many hypotheses give the same pose."""
    key = np.column_stack([np.floor(poses[:, 0] / cell_m), np.floor(poses[:, 1] / cell_m),
                           np.floor(poses[:, 3] / cell_deg)])
    _, first = np.unique(key, axis=0, return_index=True)
    return np.sort(first)


def _refine(cand: _Candidate, search: _Search) -> None:
    """Refine one candidate (:func:`refine_pose`) from the first fov tried, with its own focal length."""
    params = search.params
    cand.refined = refine_pose(search.terrain, cand.pose, search.intrinsics(search.fovs[0]), search.height, search.sky,
                               search.weights, fit_focal=search.fit_focal, f_px=cand.f_px, points=cand.points,
                               params=params.score, give_up_px=params.give_up_sweep_px, refine=params.refine,
                               focal_range=params.given_focal_range if search.fov is not None
                               else params.unknown_focal_range)
    search.stats.refined += 1
    r = cand.refined
    cand.ground_slope = float(search.model.dem.slope_deg(r.pose[0], r.pose[1]))
    search.stats.refined_poses.append(tuple(float(v) for v in (*r.pose, r.f_px, r.score)))
    search.stats.refined_slopes.append(cand.ground_slope)
