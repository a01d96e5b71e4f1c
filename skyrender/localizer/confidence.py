"""Stage 4, the last step: how sure the localizer is of its answer.

Two confidences. Renders (``LocalizeParams.confidence_model="agreement"``): the best refined pose's agreement
with the photo's skyline, discounted where a distinct pose fits almost as well (:func:`confidence_of`). Real
photographs (``"margin"``): P(within 1 km) as a logistic of the margin m = 1 - best / runner-up refined score, the
runner-up being the best refined pose farther than :data:`PHOTO_RUNNER_UP_M` from the answer
(:func:`runner_up_index`, :func:`margin_confidence`), fitted on the CH1 training side by
``python -m skyrender.training.localize_fit`` into ``photo_confidence.json`` (read here once, as the ``PHOTO_*``
constants the photo preset takes); where a second search with the fov unknown ends at the same place, its logit gains
:data:`PHOTO_SECOND_OPINION_GAIN` (:func:`agreed_confidence`). Scores are px (lower is better).
"""

from __future__ import annotations

import json
import math
import os

import numpy as np

from ..camera import Intrinsics
from ..render import Terrain, render_skylines
from .refinement import Refined
from .verification import ScoreParams, part_margins

#: The photo confidence P(within 1 km) = logistic(a + b * margin): (a, b) fitted on the CH1 training side by
#: ``python -m skyrender.training.localize_fit``, which writes this file (with ``--part-margin``, an option:
#: (a, b, 0, d), d for the answer's smallest part margin, :func:`answer_part_margin`).
PHOTO_CONFIDENCE_FILE = os.path.join(os.path.dirname(__file__), "photo_confidence.json")


#: The same confidence for a skyline a person gives instead of the extracted one (``localize --skyline`` or
#: ``--sky-mask``, :func:`~skyrender.features.given_skyline`; ``bench-real --true-skyline``): every column is trusted
#: and none is an extraction error, so the refined scores, and the margins between them, run on another scale. Fitted
#: the same way (``localize_fit --from-rows``) on the CH1 training side localized from its masks' skylines.
GIVEN_SKYLINE_CONFIDENCE_FILE = os.path.join(os.path.dirname(__file__), "given_skyline_confidence.json")


def _photo_confidence_fit(path: str = PHOTO_CONFIDENCE_FILE) -> dict:
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return {}  # not fitted yet


def _photo_margin_logit(fit: dict) -> tuple[float, ...]:
    try:
        logit = tuple(float(v) for v in fit["logit"])
    except (KeyError, TypeError, ValueError):
        return 0.0, 1.0
    return logit if len(logit) in (2, 3, 4) else (0.0, 1.0)


_FIT = _photo_confidence_fit()
PHOTO_MARGIN_LOGIT = _photo_margin_logit(_FIT)
#: Abstain below this photo confidence (a fitted P(within 1 km)), chosen by the fit's rule on
#: the training photos (``localize_fit.abstain_threshold``): above every wrong answer there, and
#: at least 0.5.
PHOTO_MIN_CONFIDENCE = float(_FIT.get("min_confidence", 0.8))
#: ... and with the fov unknown (several focal lengths searched, margins of another kind): the same rule on
#: training photos localized that way, never below :data:`PHOTO_MIN_CONFIDENCE`.
PHOTO_MIN_CONFIDENCE_FOV_UNKNOWN = float(_FIT.get("min_confidence_fov_unknown", PHOTO_MIN_CONFIDENCE))
#: The photo confidence's runner-up is the best refined pose farther than this (m) from the
#: answer, chosen with the logistic on the training photos (``localize_fit``).
PHOTO_RUNNER_UP_M = float(_FIT.get("runner_up_m", 1000.0))
#: With the fov given, an answer withheld with a confidence of at least this is searched for again with the fov unknown,
#: and where the two searches' best places lie within 1 km of each other its confidence's logit gains the second
#: (:func:`.pipeline._second_opinion`; fitted by ``localize_fit``; inf: no second opinion).
PHOTO_SECOND_OPINION_FROM = float((_FIT.get("second_opinion") or {}).get("from", math.inf))
PHOTO_SECOND_OPINION_GAIN = float((_FIT.get("second_opinion") or {}).get("gain", 0.0))
_GIVEN_FIT = _photo_confidence_fit(GIVEN_SKYLINE_CONFIDENCE_FILE) or _FIT  # the extracted skyline's until fitted
#: The photo confidence's logistic and threshold for a given skyline (:data:`GIVEN_SKYLINE_CONFIDENCE_FILE`).
GIVEN_SKYLINE_MARGIN_LOGIT = _photo_margin_logit(_GIVEN_FIT)
GIVEN_SKYLINE_MIN_CONFIDENCE = float(_GIVEN_FIT.get("min_confidence", PHOTO_MIN_CONFIDENCE))
#: ... and with the fov unknown, where fitted on training photos localized that way from their masks (else None)
GIVEN_SKYLINE_MIN_CONFIDENCE_FOV_UNKNOWN = (float(_GIVEN_FIT["min_confidence_fov_unknown"])
                                            if "min_confidence_fov_unknown" in _GIVEN_FIT else None)


def confidence_of(best: Refined, runner_up: Refined | None) -> float:
    """Agreement of the best refined pose, discounted when a distinct pose fits almost as
    well: by agreement, or by score (a wrong pose 200 m off scored 0.25 px where the
    right one scored 0.09 px, at agreements 0.96 and 1.0)."""
    if runner_up is None:
        return best.agreement
    agreement_margin = max(best.agreement - runner_up.agreement, 0.0)
    score_margin = max(1.0 - best.score / max(runner_up.score, 1e-9), 0.0)
    return float(best.agreement * min(1.0, 0.5 + 5.0 * agreement_margin + score_margin))


def runner_up_index(xy: np.ndarray, scores: np.ndarray, best: int, runner_up_m: float) -> int | None:
    """Index of the lowest-scoring pose farther than ``runner_up_m`` (m) from pose ``best``
    (``xy``: (N, 2) positions in m; ``scores``: (N,) refined scores in px, lower is better);
    None when every pose lies within that distance."""
    xy, scores = np.asarray(xy, np.float64).reshape(-1, 2), np.asarray(scores, np.float64)
    far = np.hypot(*(xy - xy[best]).T) > runner_up_m
    return int(np.flatnonzero(far)[np.argmin(scores[far])]) if far.any() else None


#: The photo confidence reads the best score as if the photo were this wide (px), so that it means the
#: same on a photo of any size (the CH1 photos it is fitted on are 1024 px wide).
SCORE_REFERENCE_WIDTH_PX = 1024.0


def log_score(score_px, width_px: float = SCORE_REFERENCE_WIDTH_PX):
    """ln of a refined verification score ``score_px`` (px, scalar or array) of a photo ``width_px``
    wide, rescaled to :data:`SCORE_REFERENCE_WIDTH_PX` (floored at 1e-3 px: a perfect fit is finite)."""
    return np.log(np.maximum(np.asarray(score_px, np.float64) * SCORE_REFERENCE_WIDTH_PX / width_px, 1e-3))


def margin_logistic(margin, logit: tuple, log_best=0.0, part_margin=0.0):
    """P(right) = 1 / (1 + exp(-(a + b m + c l + d h))) of the margin m, the log best score l
    (:func:`log_score`) and the smallest part margin h (:func:`answer_part_margin`; scalars or
    arrays) for ``logit`` = (a, b, c, d), or (a, b, c) or (a, b): the missing terms 0."""
    a, b, c, d = (*logit, 0.0, 0.0)[:4]
    return 1.0 / (1.0 + np.exp(-(a + b * np.asarray(margin, np.float64) + c * np.asarray(log_best, np.float64)
                                 + d * np.asarray(part_margin, np.float64))))


def uses_part_margin(logit: tuple) -> bool:
    """Whether a photo-confidence ``logit`` has a part-margin term (then the answer's part margin is worth rendering)."""
    return len(logit) > 3 and logit[3] != 0.0


def margin_confidence(best_score: float, runner_up_score: float, logit: tuple,
                      width_px: float = SCORE_REFERENCE_WIDTH_PX, part_margin: float = 0.0) -> float:
    """P(right) from the relative margin m = 1 - best / runner-up (scores in px of a photo
    ``width_px`` wide, lower is better) and, with a three- or four-term ``logit``, the best score itself
    and the answer's smallest part margin: :func:`margin_logistic`; no runner-up is m = 1."""
    margin = 1.0 - best_score / runner_up_score if runner_up_score > 0 and math.isfinite(runner_up_score) else 1.0
    return float(margin_logistic(margin, logit, log_score(best_score, width_px), part_margin))


#: The photo confidence's part margin (an option, ``localize_fit --part-margin``): the skyline in this many
#: equal parts, the answer against the best PART_PLACES - 1 other distinct places (each farther than the
#: runner-up distance from those before it). On the 73 CH1 training-side photos (``experiments/ch1/split-half/``)
#: halves kept 36 right answers above the fitted threshold against the margin's 32 (thirds 32), leave place out
#: 39 right / 3 wrong against 39 / 5; on the validation side, rescored once, 33 answers against 30, one of them
#: ``dsc05274`` 54 km off at 0.92 (``experiments/ch1/part-margin/``): not the shipped fit.
PART_COUNT = 2
PART_PLACES = 4


def distinct_places(poses: np.ndarray, k: int | None = None, apart_m: float = 1000.0, first: int | None = None) -> list[int]:
    """Indices of refined poses (K, 8: ..., score last), best score first (pose ``first`` before all, where
    given: an answer that is not the best-scoring), each farther than ``apart_m`` (m) from every one taken
    before it: the distinct places a row's answer is chosen among; at most ``k``."""
    kept: list[int] = []
    order = np.argsort(poses[:, 7], kind="stable")
    for i in order if first is None else [first, *order[order != first]]:
        if k is not None and len(kept) == k:
            break
        if all(np.hypot(*(poses[i, :2] - poses[j, :2])) > apart_m for j in kept):
            kept.append(int(i))
    return kept


def answer_part_margin(terrain: Terrain, refined: np.ndarray, sky: np.ndarray, weights: np.ndarray, height_px: int,
                       apart_m: float, params: ScoreParams) -> float:
    """The answer's smallest margin over the other places on :data:`PART_COUNT` parts of the skyline
    (:func:`~.verification.part_margins`): refined poses (K, 8: x, y, z, pan, tilt, swing, f_px, score),
    the answer the best-scoring; the best :data:`PART_PLACES` distinct places (:func:`distinct_places`,
    ``apart_m`` apart) rendered once. 1 where no other place was refined (as the margin)."""
    places = distinct_places(refined, PART_PLACES, apart_m)
    if len(places) < 2:
        return 1.0
    P = refined[places]
    W = len(sky)
    k = np.column_stack([P[:, 6], np.full(len(P), W / 2.0), np.full(len(P), height_px / 2.0)])
    rendered = render_skylines(terrain, P[:, :6], Intrinsics(W, height_px, P[0, 6], W / 2.0, height_px / 2.0),
                               per_pose_intrinsics=k)
    return float(part_margins(rendered, sky, weights, PART_COUNT, params).min())



def agreed_confidence(confidence: float, gain: float) -> float:
    """A confidence (a probability) whose logit gains ``gain``: an answer that a second search with the fov
    unknown agrees with (:func:`.pipeline._second_opinion`). 0 and 1 stay."""
    if confidence <= 0.0 or confidence >= 1.0:
        return float(confidence)
    z = math.log(confidence / (1.0 - confidence)) + gain
    return 1.0 / (1.0 + math.exp(-z)) if z >= 0 else math.exp(z) / (1.0 + math.exp(z))  # no overflow either way
