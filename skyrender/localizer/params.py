"""The localizer's parameters: :class:`LocalizeParams`, its two presets (``render``, the defaults, for views
rendered from the DEM itself; ``photo``, :meth:`LocalizeParams.for_photos`, for real photographs) and the
constants the photo preset is made of. :func:`.pipeline.localize` reads them stage by stage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from ..config import params_from_dict, params_to_dict
from ..errors import InputError
from ..features.skyline import SkylineParams
from .confidence import (
    GIVEN_SKYLINE_MARGIN_LOGIT,
    GIVEN_SKYLINE_MIN_CONFIDENCE,
    GIVEN_SKYLINE_MIN_CONFIDENCE_FOV_UNKNOWN,
    PHOTO_MARGIN_LOGIT,
    PHOTO_MIN_CONFIDENCE,
    PHOTO_MIN_CONFIDENCE_FOV_UNKNOWN,
    PHOTO_RUNNER_UP_M,
    PHOTO_SECOND_OPINION_FROM,
    PHOTO_SECOND_OPINION_GAIN,
    SCORE_REFERENCE_WIDTH_PX,
)
from .horizon_search import HorizonSearchParams
from .refinement import RefineParams, WeakSweepParams
from .verification import ScoreParams

#: Focal lengths tried when the field of view is unknown (horizontal fov, degrees).
FOV_CANDIDATES = (30.0, 40.0, 50.0, 60.0, 70.0)
#: ... and the photo preset's (CH1's training side: 33-57 deg)
PHOTO_FOV_CANDIDATES = (35.0, 50.0, 65.0)
#: ... and its telephoto range, searched apart: a ratio of 1.5 apart, each probe
#: (:data:`PHOTO_TELEPHOTO_STEPS`) halving the ratio: 11.4-25.7 deg with the probes (a 200 mm lens
#: on a 35 mm frame sees 10.3 deg, an 85 mm one 23.9 deg; a third of CH1's validation photos, 10.6-28 deg)
PHOTO_TELEPHOTO_FOVS = (14.0, 21.0)
PHOTO_TELEPHOTO_STEPS = (1.5 ** 0.5 - 1.0, 1.5 ** 0.25 - 1.0)
#: Real photographs stand nearly upright (hand-held, EXIF orientation applied): the camera roll
#: the photo preset's alignment and least squares may fit (deg; CH1 training oracle fits: -5.4..3.0).
PHOTO_MAX_SWING_DEG = 8.0
#: The photo preset moves every far-horizon pose (more than a fov's ~4,000) to the best of a grid around it before
#: ranking them (:func:`.pipeline.rerank_far_horizon`), with the fov given.
PHOTO_HORIZON_RERANK = 100_000


@dataclass(frozen=True)
class LocalizeParams:
    skyline_method: str = "gmm"  # the skyline extractor when none is given: "gmm" (renders) or "select" (photos)
    skyline_net_width: int | None = None  # its network's input width (px); None: the extractor's default
    n_peaks: int = 8  # image peaks taken (the paper's top N)
    max_peak_aspect: float = 1.5  # steeper skyline peaks are trees or posts in front, not mountains
    peak_smooth_px: float = 3.0  # skyline smoothing before peak finding (2 px let sub-pixel changes reorder the peaks)
    residual_px: float = 2.0  # reprojection cut-off of the three-point fit
    gn_iterations: int = 5  # Gauss-Newton steps of the three-point position after the closed form
    prior_boost: float = 1000.0  # added to the log probability of model triples holding a prior's feature
    limit_tol_px: float = 5.0  # "skyline is the limit" tolerance (plus f * 150 m / distance)
    chunk: int = 50_000  # hypotheses solved per batch
    max_hypotheses: int = 1_200_000  # then abstain (on 50 rendered views the first right one came by 1.1 M but once)
    neighbours: str = "nearest"  # model triples: an anchor's k nearest (the paper's) or "covisible" features
    neighbours_k: int | None = None  # ... this many of them (None: the model's k)
    verify_stride: int = 4  # every n-th column in the verification renders
    confidence_power: float = 1.0  # column weights = the skyline's per-column confidence (>= 0.05) to this power
    # a photo wider than this (px) is searched on its skyline reduced to this many columns (:func:`.pipeline.reduce_skyline`):
    # poses are angles and come out the same, every pixel threshold means what it means on photos this wide, and a
    # 12 MP photo renders as many columns as a 1,024-wide one; the result is given in the photo's own pixels.
    # None: searched at its own width (the render preset)
    search_width: int | None = None
    refine_per_chunk: int = 1  # best new candidates (by each score) refined after each chunk
    final_refinements: int = 3  # distinct candidates refined at the end
    max_refinements: int = 16  # refinements of three-point candidates in all (each ~0.3 s)...
    max_horizon_refinements: int = 8  # ...and of far-horizon ones, each budget apart: neither crowds out the other
    # before abstaining, the best far-horizon candidates not yet refined, this many by each ranking, are refined
    # and the answer decided again: the 1" tile row's view 4 had its near-truth pose 9th by score, one past the
    # budget (experiments/scale/escalation/); only a search about to abstain pays for it
    escalate_refinements: int = 4
    # if it still abstains, every far-horizon pose is moved to the best of a rescore_grid^2 grid +-rescore_half_m (m)
    # around it, scored on every rescore_stride-th column (local_rescore), and the best this many, distinct from the
    # poses refined already, are refined: a pose a few hundred metres from a camera under a near ridge scores like
    # a wrong place where it lies (the 1" tile row's view 3: 259 m off, 329th by score; moved, 131 m off and 1st)
    rescore_refinements: int = 6
    rescore_grid: int = 7
    rescore_half_m: float = 300.0
    rescore_stride: int = 32
    give_up_sweep_px: float = 1.5  # a refinement whose first stage fits no better than this stops there
    accept_score_px: float = 0.3  # stop early once a refined pose scores this well...
    accept_agreement: float = 0.95  # ...and agrees on this share of columns
    # then go on this many chunks: a pose tens of metres off can score that well too. 1 since 2026-12-03: on 26
    # rendered views (bench-localize's 10, bench-scale's synthetic 8 and 8 tile views of seed 1) a second chunk
    # changed one answer, by 1.2 m, for 0.2-1.6 s a view (experiments/scale/README.md)
    confirm_chunks: int = 1
    # stop rule (no prior, ordered): the search stops when the last stall_chunks chunks bettered none of the
    # best verified, trusted and refined scores by more than stall_gain (a share; 0 chunks: never). A 5 % gain
    # cut the whole tile's max 74.5 -> 43.8 s but lost a 20 %-occluded test view found in chunk 19 after 17 chunks
    # of < 2 % gains; 0 loses none measured: experiments/scale/README.md
    stall_chunks: int = 8
    stall_gain: float = 0.0
    min_confidence: float = 0.7  # abstain below this (wrong poses scored 0.51-0.59 on test views)
    min_confidence_fov_unknown: float | None = None  # ... when the fov is unknown (None: min_confidence)
    # a second opinion (:func:`.pipeline._second_opinion`): with the fov given, an answer about to be withheld with a
    # confidence of at least second_opinion_from (inf: never) is searched for again with the fov unknown, and
    # where the two searches' best places lie within second_opinion_m (m) of each other its confidence's logit
    # gains second_opinion_gain (fitted on the CH1 training side: experiments/ch1/mode-agreement/)
    second_opinion_from: float = math.inf
    second_opinion_m: float = 1000.0
    second_opinion_gain: float = 0.0
    same_pose_m: float = 150.0  # candidates closer than this (and same heading) are one
    runner_up_m: float | None = None  # confidence: the runner-up is the best refined pose this far away (None: distinct)
    confidence_model: str = "agreement"  # "agreement" (renders) or "margin": P(right) from the runner-up's margin
    # "margin": P = 1 / (1 + exp(-(a + b m + c ln s))), m = 1 - best / runner-up score, s the best score (px at
    # SCORE_REFERENCE_WIDTH_PX wide); (a, b) or (a, b, c): confidence.margin_logistic
    margin_logit: tuple = (0.0, 1.0)
    ordered: bool = True  # probabilistic ordering (False: a seeded arbitrary order)
    use_horizons: bool = True  # also match the skyline against the model's far horizons (no peaks needed)
    horizon: HorizonSearchParams = field(default_factory=HorizonSearchParams)
    fov_candidates: tuple = FOV_CANDIDATES  # unknown fov: horizontal fovs (deg) tried first
    horizon_fov_step: tuple = (5.0, 2.5, 1.25)  # unknown fov: probes around the best fov of the far-horizon search
    # unknown fov: a telephoto range searched apart (horizontal fovs, deg; empty: none), its probes as ratios
    # (at best / (1 + s) and best * (1 + s), within the range widened by the first), and how many of its
    # candidates are refined by each ranking beside the others (a wrong place fits a narrow view better
    # than the right place a wide one before refinement, not after: experiments/ch1/fov-unknown-range/)
    telephoto_fovs: tuple = ()
    telephoto_fov_step: tuple = ()
    telephoto_refinements: int = 4
    # unknown fov: the far-horizon candidates of each coarse fov (fov_candidates) other than the two best-fitting
    # join too (lens 2), and this many of them by each ranking are refined beside the others (0: none). The focal
    # length is free, so the answer's margin should be taken against places found at other focal lengths as well,
    # not only against places at its own (experiments/ch1/other-fov-runner-up/)
    other_fov_refinements: int = 0
    # ... which search only the horizon centres of the poses kept at the fovs tried before (False: every centre)
    fov_probes_on_found: bool = True
    # the answer and its runner-up are taken among refined poses whose ground slopes at most this (deg;
    # all of them where none does; inf: no bound). People photograph from ground they stand on (the CH1
    # training-side cameras: 0-27 deg of SRTM3 slope; refined wrong places: a quarter over 29 deg), but 35
    # moved no validation answer and its refitted threshold answered one 54 km wrong: an option, not in
    # the photo preset (experiments/ch1/standable/)
    max_answer_slope_deg: float = math.inf
    # far-horizon search: only horizon centres whose ground slopes at most this (deg; inf: every centre)
    max_ground_slope_deg: float = math.inf
    # far-horizon poses: the best this many by each ranking are moved to the best of a rerank_grid^2
    # grid +-rerank_half_m (m) around them, that score their first ranking (0: off; the photo preset
    # moves every one, with the fov given: PHOTO_HORIZON_RERANK)
    horizon_rerank: int = 0
    rerank_half_m: float = 250.0
    rerank_grid: int = 5
    # the re-ranking's renders on every n-th column of a skyline SCORE_REFERENCE_WIDTH_PX wide, in proportion on
    # others (None: verify_stride, not scaled). The photo preset searches no skyline wider than that (search_width),
    # so there the scaling only thins the renders of a narrower photo
    rerank_stride: int | None = None
    rerank_fov_unknown: bool = True  # ... with the fov unknown too (False: only with the fov given)
    # ... and then the best this many by each ranking at each of its two best fovs, the rest left out (None:
    # horizon_rerank). The photo preset's 300 of its ~4,000: the right places the full re-ranking puts first lay
    # among the search's best 300 by score at one of the two fovs (experiments/ch1/rerank-screen/)
    horizon_rerank_fov_unknown: int | None = None
    # a given fov is only a start: every candidate's refinement fits the focal length too, within given_focal_range
    # (a fraction) of the given one. Not for an EXIF fov (the CLI's until 2026-12-05: unbounded, on the CH1 training
    # side it answered 2 photos 1.7 and 69 km off at 0.98 and 0.95; experiments/ch1/exif-fov/), nor in the photo
    # preset: on the CH1 training side it brought right answers closer at the one place whose given focal lengths are
    # ~4 % short and nowhere else, and on validation it answered 2 photos 1.1-2.3 km wrong
    # (experiments/ch1/refine-fov-known/)
    refine_fov: bool = False
    given_focal_range: float = math.inf
    # with the fov unknown, each candidate's refinement fits its focal length within this fraction of the fov it was
    # found at (the search's fovs lie 2.5 deg apart at the end: a right one is within ~3 %); inf: unbounded
    unknown_focal_range: float = math.inf
    score: ScoreParams = field(default_factory=ScoreParams)
    refine: RefineParams = field(default_factory=RefineParams)  # the refinement's search set-up
    # before abstaining, the first chunks' weakly held three-point poses are moved along their weak axis
    # (bench-localize view 7: the right hypothesis solved 283 m off, verified 272nd of 318; swept, first at 4 m)
    weak_sweep: WeakSweepParams = field(default_factory=WeakSweepParams)

    def abstain_below(self, fov_unknown: bool) -> float:
        """The confidence an answer needs: ``min_confidence``, or with the fov unknown
        ``min_confidence_fov_unknown`` where set."""
        if fov_unknown and self.min_confidence_fov_unknown is not None:
            return self.min_confidence_fov_unknown
        return self.min_confidence

    @property
    def places_apart_m(self) -> float:
        """How far apart (m) two refined poses lie to be distinct places (the answer's part margin,
        :meth:`.result.LocalizationResult.places`): the confidence's runner-up distance, or ``same_pose_m`` without one."""
        return self.runner_up_m or self.same_pose_m

    @classmethod
    def for_photos(cls) -> "LocalizeParams":
        """Real photographs, where the DEM never matches exactly (the oracle fit at the
        true position leaves 1.4-7.4 px, ``make oracle``): the far-horizon search turns
        the skyline into directions for tilts from -10 to +30 deg, fits offset and slope
        only, every pose it finds is moved to the best of a grid around it (with the fov given), and
        the best 8 of them by its own cost and 8 by verification score are refined; the skyline
        comes from ``select`` (the learned extractor, or the per-photo mixtures
        where they part from it and are surer: on the 21 CH1 dev photos 13 within 1 km against 12
        with the learned extractor alone, ``experiments/ch1/select/``). Three-point hypotheses
        are off (on CH1 their peaks are rarely DEM peaks; generating them took 10-30 s). The refined scores of right and
        wrong poses overlap (1.1-2.4 vs 1.1-4.0 px on CH1 training photos), but the
        margin to the best pose farther away (:data:`.confidence.PHOTO_RUNNER_UP_M`) separates them, so the
        confidence is a logistic of that margin fitted on the CH1 training side (:data:`.confidence.PHOTO_MARGIN_LOGIT`;
        a term of the best score was tried and did not hold on places left out, and one of the answer's
        smallest margin on either half of the skyline, :func:`.confidence.answer_part_margin`, kept more right
        training answers but answered a validation photo 54 km wrong: ``localize_fit``).
        The camera roll stays within :data:`PHOTO_MAX_SWING_DEG` in the verification's alignment
        and the refinement: wrong places fitted with 10-50 deg of it (held in the far-horizon
        fit too, ``HorizonSearchParams.max_swing_deg``, it lost a confident answer on the CH1 dev photos).
        A photo wider than 1,024 px is searched on its skyline reduced to 1,024 columns (``search_width``):
        CH1 photos scaled up 4x were localized in half the time and 9 of 9 right instead of 6
        (``experiments/ch1/search-width/``). With the fov given, an answer withheld with a confidence of at least
        :data:`.confidence.PHOTO_SECOND_OPINION_FROM` asks a search with the fov unknown, and is given where that search ends
        within 1 km of it (:func:`.pipeline._second_opinion`): on the 73 CH1 training-side photos the two agree on 30 of the
        51 right answers and none of the 22 wrong ones (``experiments/ch1/mode-agreement/``). For a photo
        narrower than 27.5 deg that search's fovs are scaled to the given one (:func:`.pipeline.second_opinion_params`;
        ``experiments/ch1/telephoto-second-opinion/``)."""
        return cls(skyline_method="select", max_hypotheses=0, final_refinements=8, max_refinements=4,
                   max_horizon_refinements=16, escalate_refinements=0, rescore_refinements=0,
                   # fov unknown: 3 coarse fovs and 4 probes instead of 5 and 6 (the refinement fits the focal
                   # length): on 20 training photos the same or better answers in 41.0 s instead of 64.7 s
                   # (experiments/ch1/fov-unknown-fast/). They never come below 30 deg; the telephoto range
                   # (telephoto_fovs=PHOTO_TELEPHOTO_FOVS, ...) is not in the preset: on the 41 training-side
                   # photos it kept every answer and added one within 1 km, but the mode's threshold stays 1.00
                   # and its median rose 27 -> 39 s (experiments/ch1/fov-unknown-range/)
                   fov_candidates=PHOTO_FOV_CANDIDATES, horizon_fov_step=(5.0, 2.5),
                   give_up_sweep_px=math.inf, same_pose_m=300.0, runner_up_m=PHOTO_RUNNER_UP_M, confidence_model="margin",
                   margin_logit=PHOTO_MARGIN_LOGIT, min_confidence=PHOTO_MIN_CONFIDENCE,
                   min_confidence_fov_unknown=PHOTO_MIN_CONFIDENCE_FOV_UNKNOWN,
                   second_opinion_from=PHOTO_SECOND_OPINION_FROM,
                   second_opinion_gain=PHOTO_SECOND_OPINION_GAIN,
                   score=ScoreParams(max_swing_deg=PHOTO_MAX_SWING_DEG),
                   # every far-horizon pose moved to the best of a 7 x 7 grid +-300 m around it (renders on every 32nd
                   # column) before the best are refined: a pose a few hundred metres from a camera under ridges
                   # 1-4 km away scores like a wrong place where it lies. On CH1-like renders of a DEM that is the
                   # world (experiments/dem-mismatch/: Glarus 1", Big Tujunga 30 m) 24 -> 29 of 32 best places
                   # within 1 km; on the 73 CH1 training-side photos 45 -> 50, 41 right answers kept above the
                   # refitted threshold instead of 32 (experiments/ch1/rerank-all/); 25 s a photo instead of 15.
                   # With the fov unknown too, at its two best fovs, and with the candidates of its other coarse fovs
                   # refined beside them (2 by each ranking), so that an answer's margin is taken against places
                   # found at other focal lengths as well: on the 41 training-side photos 14 -> 18 best places
                   # within 1 km, and the mode's threshold 0.95 instead of 1.00 (neither alone brought it below
                   # 1.00: experiments/ch1/other-fov-runner-up/, ../rerank-fov-unknown/). There only the best 300
                   # poses by each ranking are moved: on the 41 training-side photos 17 within 1 km instead of 18 and
                   # 13 answered (all right) instead of 14, on validation the same 24 of 60 answered (all right), in
                   # 33.8 s a photo instead of 45.2 (experiments/ch1/rerank-cut-fov-unknown/)
                   horizon_rerank=PHOTO_HORIZON_RERANK, rerank_grid=7, rerank_half_m=300.0, rerank_stride=32,
                   rerank_fov_unknown=True, horizon_rerank_fov_unknown=300, other_fov_refinements=2,
                   search_width=int(SCORE_REFERENCE_WIDTH_PX),
                   horizon=HorizonSearchParams(tilts=(-10.0, 0.0, 10.0, 20.0, 30.0), terms=2, rank_by_cost=True))

    def for_given_skyline(self) -> "LocalizeParams":
        """These parameters for a skyline a person gives (:func:`~skyrender.features.given_skyline`: every column
        trusted) instead of one extracted: with the photo confidence (``"margin"``) its fit on given skylines
        (:data:`.confidence.GIVEN_SKYLINE_MARGIN_LOGIT`) and that fit's thresholds (with the fov unknown, the one
        fitted on fov-unknown localizations from given skylines; without one, never below the extracted skyline's
        there), and no second opinion (fitted on extracted skylines only). With another confidence model, unchanged."""
        if self.confidence_model != "margin":
            return self
        unknown = (GIVEN_SKYLINE_MIN_CONFIDENCE_FOV_UNKNOWN if GIVEN_SKYLINE_MIN_CONFIDENCE_FOV_UNKNOWN is not None
                   else max(GIVEN_SKYLINE_MIN_CONFIDENCE, self.abstain_below(fov_unknown=True)))
        return replace(self, margin_logit=GIVEN_SKYLINE_MARGIN_LOGIT, min_confidence=GIVEN_SKYLINE_MIN_CONFIDENCE,
                       min_confidence_fov_unknown=unknown, second_opinion_from=math.inf)

    def skyline_params(self) -> SkylineParams:
        """The skyline extractor's parameters this localization extracts with."""
        if self.skyline_net_width is None:
            return SkylineParams(method=self.skyline_method)
        return SkylineParams(method=self.skyline_method, net_width=self.skyline_net_width)

    @classmethod
    def preset(cls, name: str) -> "LocalizeParams":
        """The named parameter set: ``render`` (the defaults) or ``photo`` (:meth:`for_photos`)."""
        if name not in PRESETS:
            raise InputError(f"unknown preset {name!r} (one of {', '.join(PRESETS)})")
        return PRESETS[name]()

    def to_dict(self) -> dict:
        """Every field as plain values (nested groups as dicts), e.g. for JSON results."""
        return params_to_dict(self)

    @classmethod
    def from_dict(cls, data: dict, base: "LocalizeParams | None" = None) -> "LocalizeParams":
        """``base`` (default: the defaults) with the fields in ``data`` set; InputError names
        an unknown field or a value of the wrong kind."""
        return params_from_dict(cls, data, base)


#: Named parameter sets (``--preset``, experiment configs).
PRESETS = {"render": LocalizeParams, "photo": LocalizeParams.for_photos}
