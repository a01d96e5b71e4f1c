"""The localizer's photo-side search and answer: the far-horizon search (over tilts, fovs and grids), the
margin confidence and its fits, the second opinion, the fov-unknown mode, the horizon costs' kernels, the
real-photo benchmark's rows. The stages and the render preset end to end: ``test_localizer.py``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from skyrender.camera import Intrinsics, Pose
from skyrender.localizer import LocalizeParams, localize
from skyrender.localizer.refinement import refine_pose
from skyrender.localizer.verification import ScoreParams
from skyrender.render import render_skylines

from .conftest import POS_TOL_M, K, assert_localized_near, photo_of


def test_far_horizon_search_puts_the_camera_among_its_poses(scene, views):
    """View 3: a ridge 250 m away fills a third of the frame and no three of its skyline
    peaks form a model triple. Matching the skyline (and its right part) against the
    model's far horizons still gives a pose within a grid step of the camera, looking
    the right way, and the verification ranks it near the top."""
    from skyrender.features import extract_skyline
    from skyrender.localizer.horizon_search import horizon_poses
    from skyrender.localizer.verification import verify_poses

    dem, terrain, model = scene
    pose = views.poses[3]
    sky = extract_skyline(photo_of(terrain, pose))
    poses, cost = horizon_poses(model.horizons, sky.skyline, sky.confidence, K, dem, 2.0)
    assert len(poses) == len(cost) > 100 and np.all(np.diff(cost) >= 0)
    step = np.sqrt(2.0) * 250.0 / 2.0
    near = (np.hypot(poses[:, 0] - pose.x, poses[:, 1] - pose.y) <= step + 1.0) & (
        np.abs((poses[:, 3] - pose.pan + 180.0) % 360.0 - 180.0) <= 3.0)
    assert near.any()
    assert np.abs(poses[near, 4] - pose.tilt).min() < 1.0  # the fitted offset is the tilt
    score, trusted = verify_poses(terrain, poses, K, sky.skyline, sky.confidence)
    assert min((score < score[near].min()).sum(), (trusted < trusted[near].min()).sum()) < 12


def test_far_horizon_search_over_a_subset_of_centres(scene, views):
    """The unknown fov's probes search only the centres earlier fovs found: over every centre
    the search is the full one; over the centres of the full search's poses it finds the same
    best pose, and only poses at those centres."""
    from skyrender.features import extract_skyline
    from skyrender.localizer.horizon_search import centre_indices, horizon_poses

    dem, terrain, model = scene
    sky = extract_skyline(photo_of(terrain, views.poses[3]))
    poses, cost = horizon_poses(model.horizons, sky.skyline, sky.confidence, K, dem, 2.0)
    every, every_cost = horizon_poses(model.horizons, sky.skyline, sky.confidence, K, dem, 2.0,
                                      centres=np.arange(len(model.horizons)))
    assert np.array_equal(every, poses) and np.array_equal(every_cost, cost)
    found = centre_indices(model.horizons, poses[:, :2])
    assert np.all(found >= 0) and np.allclose(model.horizons.centres[found, :2], poses[:, :2])
    subset = np.unique(found)[::2]  # half of them, the best among them
    subset = np.union1d(subset, found[:1])
    sub, sub_cost = horizon_poses(model.horizons, sky.skyline, sky.confidence, K, dem, 2.0, centres=subset)
    assert np.allclose(sub[0], poses[0]) and sub_cost[0] == cost[0]
    assert set(centre_indices(model.horizons, sub[:, :2]).tolist()) <= set(subset.tolist())
    assert centre_indices(model.horizons, np.array([[1e9, 1e9]]))[0] == -1


def test_far_horizon_search_over_tilts_finds_a_camera_looking_up(scene, views):
    """Photos look up at the ridges above them (CH1: up to 30 deg): with the skyline
    turned into directions for tilts 0, 10, 20 and 30 deg, the search still gives a
    pose within a grid step of a camera tilted 20 deg up, with that tilt (+-1 deg)."""
    from skyrender.features import extract_skyline
    from skyrender.localizer.horizon_search import HorizonSearchParams, horizon_poses

    dem, terrain, model = scene
    p = views.poses[3]
    pose = Pose(p.x, p.y, p.z, p.pan, 20.0, 0.0)
    sky = extract_skyline(photo_of(terrain, pose))
    params = HorizonSearchParams(tilts=(0.0, 10.0, 20.0, 30.0), terms=2)
    poses, cost = horizon_poses(model.horizons, sky.skyline, sky.confidence, K, dem, 2.0, params)
    step = np.sqrt(2.0) * 250.0 / 2.0
    near = (np.hypot(poses[:, 0] - pose.x, poses[:, 1] - pose.y) <= step + 1.0) & (
        np.abs((poses[:, 3] - pose.pan + 180.0) % 360.0 - 180.0) <= 3.0)
    assert near.any()
    assert np.abs(poses[near, 4] - 20.0).min() < 1.0


def test_photo_confidence_is_a_logistic_of_the_margin_to_the_runner_up():
    from skyrender.localizer.confidence import margin_confidence

    assert margin_confidence(1.0, 2.0, (0.0, 1.0)) == pytest.approx(1.0 / (1.0 + np.exp(-0.5)))
    assert margin_confidence(1.0, np.inf, (-2.0, 4.0)) == pytest.approx(1.0 / (1.0 + np.exp(-2.0)))  # no runner-up
    # a runner-up as good as the best leaves only the prior; a better margin raises it
    assert margin_confidence(2.0, 2.0, (-3.0, 10.0)) < margin_confidence(1.5, 2.0, (-3.0, 10.0))
    # the score term: at the same margin the better fit is the surer, and a score means the same at any width
    logit = (0.2, 17.0, -5.4)
    assert margin_confidence(1.0, 1.2, logit) > margin_confidence(2.0, 2.4, logit)
    assert margin_confidence(1.0, 1.2, logit) == pytest.approx(1 / (1 + np.exp(-(0.2 + 17.0 * (1 - 1 / 1.2)))))
    assert margin_confidence(4.0, 4.8, logit, width_px=4096) == pytest.approx(margin_confidence(1.0, 1.2, logit))
    photo = LocalizeParams.for_photos()
    assert photo.confidence_model == "margin" and photo.runner_up_m >= 1000.0 and photo.horizon.terms == 2


def test_a_given_skyline_takes_the_confidence_fitted_for_given_skylines():
    """``for_given_skyline`` (``localize --skyline / --sky-mask``, ``bench-real --true-skyline``): the photo preset's
    margin logistic and thresholds become those fitted on skylines given that way (with the fov unknown, where none was
    fitted, never below the extracted skyline's threshold), and no second opinion (fitted on extracted skylines); the
    render preset, whose confidence is the agreement, is unchanged."""
    from skyrender.localizer.confidence import (
        GIVEN_SKYLINE_MARGIN_LOGIT,
        GIVEN_SKYLINE_MIN_CONFIDENCE,
        GIVEN_SKYLINE_MIN_CONFIDENCE_FOV_UNKNOWN,
    )

    photo = LocalizeParams.for_photos()
    given = photo.for_given_skyline()
    assert given.margin_logit == GIVEN_SKYLINE_MARGIN_LOGIT and given.min_confidence == GIVEN_SKYLINE_MIN_CONFIDENCE
    assert given.abstain_below(fov_unknown=True) == (
        GIVEN_SKYLINE_MIN_CONFIDENCE_FOV_UNKNOWN if GIVEN_SKYLINE_MIN_CONFIDENCE_FOV_UNKNOWN is not None
        else max(GIVEN_SKYLINE_MIN_CONFIDENCE, photo.abstain_below(True)))
    assert given.second_opinion_from == np.inf and photo.second_opinion_from < np.inf
    assert given.horizon == photo.horizon and given.skyline_method == photo.skyline_method  # the search as before
    assert LocalizeParams().for_given_skyline() == LocalizeParams()



def test_the_part_margin_finds_a_look_alike_that_wins_on_one_part_only():
    """part_margins: the first rendered skyline's margin over the others on each part; an answer that
    fits both halves best is positive on both, a look-alike that wins the whole on the strength of one
    half is negative on the other."""
    from skyrender.localizer.verification import part_margins

    W = 200
    image = np.full(W, 100.0)
    right = image + 1.0  # 1 px off everywhere
    other = image + np.where(np.arange(W) < W // 2, 4.0, 2.0)
    m = part_margins(np.stack([right, other]), image, np.ones(W), 2, ScoreParams())
    assert m.shape == (2,) and (m > 0).all()
    assert m[0] == pytest.approx(1 - 1 / 4) and m[1] == pytest.approx(1 - 1 / 2)
    lookalike = image + np.where(np.arange(W) < W // 2, 0.2, 2.5)  # better overall (1.35 against 1.5 px)...
    fair = image + 1.5
    m = part_margins(np.stack([lookalike, fair]), image, np.ones(W), 2, ScoreParams())
    assert m[0] > 0 > m[1]  # ...but worse on the right half
    # a part's weights alone count: zero weight on the look-alike's bad half hides it
    m = part_margins(np.stack([lookalike, fair]), image, (np.arange(W) < W // 2).astype(float), 2, ScoreParams())
    assert m[0] > 0


def test_the_answers_part_margin_is_rendered_against_the_other_distinct_places(view_terrain, valley_view):
    from skyrender.localizer.confidence import answer_part_margin, distinct_places, margin_logistic, uses_part_margin
    from skyrender.render import render_skylines

    pose, K = valley_view
    p = pose.array()
    sky = render_skylines(view_terrain, p, K)
    away = p.copy()
    away[:2] += 3000.0  # another place, 4.2 km off
    near = p.copy()
    near[0] += 300.0  # the answer's own place, within 1 km: not a rival
    refined = np.array([[*p, K.f_px, 0.1], [*near, K.f_px, 0.2], [*away, K.f_px, 3.0]])
    assert distinct_places(refined, 4, 1000.0) == [0, 2]
    h = answer_part_margin(view_terrain, refined, sky, np.ones(K.width), K.height, 1000.0, LocalizeParams().score)
    assert 0.5 < h <= 1.0  # the answer renders the photo's skyline; the other place fits neither half
    assert answer_part_margin(view_terrain, refined[:2], sky, np.ones(K.width), K.height, 1000.0,
                              LocalizeParams().score) == 1.0  # no other place: as the margin without a runner-up
    # the four-term logistic: (a, b, 0, d) adds d h; with d = 0 it is the two-term one
    assert margin_logistic(0.3, (-2.0, 10.0, 0.0, 5.0), 0.0, -0.2) == pytest.approx(1 / (1 + np.exp(-(-2 + 3 - 1))))
    assert margin_logistic(0.3, (-2.0, 10.0, 0.0, 0.0), 0.0, 0.7) == pytest.approx(margin_logistic(0.3, (-2.0, 10.0)))
    assert uses_part_margin((-2.0, 10.0, 0.0, 5.0)) and not uses_part_margin((-2.0, 10.0))
    photo = LocalizeParams.for_photos()
    assert uses_part_margin(photo.margin_logit) == (len(photo.margin_logit) > 3 and photo.margin_logit[3] != 0)


def test_a_benchmark_run_is_rescored_under_another_confidence_without_moving_a_pose():
    from skyrender.benchmarks.real_localize import rescore

    rows = [{"photo": "a", "status": "localized", "confidence": 0.9, "best_score": 1.0, "runner_up_score": 2.0,
             "error_m": 120.0},
            {"photo": "b", "status": "localized", "confidence": 0.6, "best_score": 1.8, "runner_up_score": 2.0,
             "error_m": 40000.0},
            {"photo": "c", "status": "abstained", "confidence": 0.1, "best_score": 2.0, "runner_up_score": 2.0}]
    out = rescore(rows, (-3.0, 20.0), 0.9)  # margins 0.5, 0.1, 0
    assert [r["status"] for r in out] == ["localized", "abstained", "abstained"]
    assert out[0]["error_m"] == 120.0 and out[1]["withheld_error_m"] == 40000.0 and "error_m" not in out[1]
    assert rows[1]["status"] == "localized"  # the input is left as it was
    with pytest.raises(ValueError, match="run the benchmark again"):
        rescore(rows, (5.0, 0.0), 0.5)  # would answer for c, whose pose the run did not keep
    again = rescore(out[:2], (-3.0, 20.0), 0.1)  # b's withheld answer is given again under a lower threshold
    assert again[1]["status"] == "localized" and again[1]["error_m"] == 40000.0 and "withheld_error_m" not in again[1]


def test_the_runner_up_is_the_best_pose_beyond_the_distance():
    from skyrender.localizer.confidence import runner_up_index

    xy = np.array([[0.0, 0.0], [500.0, 0.0], [0.0, 2500.0], [4000.0, 0.0]])
    scores = np.array([1.0, 1.05, 1.2, 1.5])
    assert runner_up_index(xy, scores, 0, 300.0) == 1
    assert runner_up_index(xy, scores, 0, 1000.0) == 2
    assert runner_up_index(xy, scores, 0, 3000.0) == 3
    assert runner_up_index(xy, scores, 0, 5000.0) is None
    assert runner_up_index(xy, scores, 3, 3000.0) == 0  # measured from the given pose


def test_a_rescore_takes_the_runner_up_from_the_rows_refined_poses():
    from skyrender.benchmarks.real_localize import margin_of, rescore

    # the answer (score 1) has a near rival 1.5 km away (1.05) and a far one 6 km away (2)
    poses = [[0, 0, 2, 10, 5, 0, 800, 1.0], [1500, 0, 2, 12, 5, 0, 800, 1.05], [0, 6000, 2, 90, 5, 0, 800, 2.0]]
    row = {"photo": "a", "status": "localized", "confidence": 0.1, "best_score": 1.0, "runner_up_score": 1.05,
           "error_m": 300.0, "refined_poses": poses}
    assert margin_of(row, 1000.0) == pytest.approx(1 - 1 / 1.05)
    assert margin_of(row, 3000.0) == pytest.approx(0.5)
    assert margin_of(row, 10000.0) == 1.0
    assert margin_of({"best_score": 1.0, "runner_up_score": 2.0}, 3000.0) == 0.5  # no poses kept: the run's runner-up
    assert np.isnan(margin_of({"best_score": None}))
    assert rescore([row], (-3.0, 20.0), 0.9, 1000.0)[0]["status"] == "abstained"
    out = rescore([row], (-3.0, 20.0), 0.9, 3000.0)[0]
    assert out["status"] == "localized" and out["confidence"] == pytest.approx(1 / (1 + np.exp(-7.0)))


def test_a_probe_report_counts_best_places_within_a_km_and_their_margins(tmp_path, capsys):
    """place_report (the stored-pose probes' summary): per score, the photos whose best-scoring place lies
    within 1 km, and the median margin 1 - best / next of those and of the others; the records are written."""
    from skyrender.benchmarks.real_localize import place_report

    records = [{"dist_m": [200.0, 40000.0], "scores": {"a": [1.0, 2.0], "b": [3.0, 2.0]}},
               {"dist_m": [30000.0, 500.0, 9000.0], "scores": {"a": [1.0, 1.25, 4.0], "b": [5.0, 1.0, 0.0]}}]
    place_report(records, ["a", "b"], str(tmp_path / "out.json"))
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "a: best place within 1000 m on 1 of 2; margin median right 0.500, wrong 0.200"
    # b: photo 1's best place is 40 km off (margin 1/3); photo 2's is 9 km off, its next scores 1 (margin 1)
    assert lines[1] == "b: best place within 1000 m on 0 of 2; margin median right nan, wrong 0.667"
    assert json.loads((tmp_path / "out.json").read_text()) == records


def test_the_answer_and_its_runner_up_stand_on_ground_a_person_stands_on():
    """refined_of / margin_of with the rows' refined_slopes and the bound their run used: a pose on a
    50 deg cliff is neither the answer nor the runner-up; where every pose is on a cliff all count; a
    row of a run without the bound (or without slopes) is read as it was."""
    from skyrender.benchmarks.real_localize import log_best_of, margin_of, refined_of

    poses = [[0, 0, 2, 0, 0, 0, 800, 0.9],  # the best score, on a cliff
             [3000, 0, 2, 0, 0, 0, 800, 1.0], [9000, 0, 2, 0, 0, 0, 800, 1.1],  # a cliff, then level ground
             [0, 5000, 2, 0, 0, 0, 800, 2.0]]
    row = {"refined_poses": poses, "refined_slopes": [50.0, 12.0, 48.0, 3.0], "max_answer_slope_deg": 35.0}
    assert refined_of(row, 35.0)[:, 7].tolist() == [1.0, 2.0]
    assert margin_of(row, 1000.0) == pytest.approx(1 - 1.0 / 2.0)  # not 1 - 0.9 / 1.0
    assert log_best_of(row) == pytest.approx(np.log(1.0))
    assert len(refined_of(row, 60.0)) == 4 and len(refined_of(row, 2.0)) == 4  # no bound / every pose over it
    assert margin_of({"refined_poses": poses}, 1000.0) == pytest.approx(1 - 0.9 / 1.0)
    assert margin_of({**row, "max_answer_slope_deg": np.inf}, 1000.0) == pytest.approx(1 - 0.9 / 1.0)


def test_the_photo_confidence_fit_takes_the_runner_up_distance_that_keeps_most_right_answers():
    from skyrender.training.localize_fit import fit_confidence

    rows = []
    for n in range(12):  # right answers, half of them with a rival 2 km away that sees the same skyline
        best, near = 1.0 + 0.05 * n, [[2000, 0, 2, 0, 0, 0, 800, (1.0 + 0.05 * n) * 1.005]] if n % 2 else []
        rows.append({"photo": f"r{n}", "error_m": 200.0, "seconds": 1.0, "refined_poses": [
            [0, 0, 2, 0, 0, 0, 800, best], *near, [9000, 0, 2, 0, 0, 0, 800, best * 2]]})
    for n in range(12):  # wrong answers with a rival 8 km away nearly as good
        best = 1.5 + 0.05 * n
        rows.append({"photo": f"w{n}", "error_m": 30000.0, "seconds": 1.0, "refined_poses": [
            [0, 0, 2, 0, 0, 0, 800, best], [8000, 0, 2, 0, 0, 0, 800, best * (1.01 + 0.002 * n)]]})
    fit = fit_confidence(rows, choices_m=(1000.0, 3000.0, 10000.0), score_term=False)  # the margin alone
    # beyond 1 km the near rivals hold back half the right answers, beyond 3 km none
    assert fit["runner_up_m"] == 3000.0 and fit["right"] == 12 and fit["photos"] == 24
    assert fit["kept_by_runner_up_m"] == {"1000": 6, "3000": 12, "10000": 0}  # 10 km: no rival left, no margin
    a, b = fit["logit"]
    assert b > 0 and 0.5 <= fit["min_confidence"] <= 1.0
    assert set(fit["leave_place_out"]) == {"margin", "margin+score"}
    assert len(fit_confidence(rows, choices_m=(3000.0,), score_term=True)["logit"]) == 3
    # the part margin in the place of the score term: right answers win both halves, wrong ones lose one
    for r in rows:
        r["part_margin"] = 0.3 if r["photo"].startswith("r") else -0.1
    fit = fit_confidence(rows, choices_m=(1000.0,), part_term=True)
    a, b, c, d = fit["logit"]
    assert c == 0.0 and d > 0 and set(fit["leave_place_out"]) == {"margin", "margin+part"}
    assert fit["kept_by_runner_up_m"]["1000"] == 12  # the near rivals no longer hold the right answers back


def test_the_score_term_answers_right_answers_the_margin_alone_cannot_tell_from_wrong_ones():
    """Right answers that win by small margins but fit well, wrong ones with the same margins that fit
    badly: the margin alone must withhold the right ones, margin and score (``--score-term``) answer
    them; judged a place at a time (here every photo its own place)."""
    from skyrender.training.localize_fit import fit_confidence

    rows = []
    for n in range(10):
        margin = 0.05 + 0.03 * n  # the same margins for right and wrong answers
        for name, best, error in (("r", 0.8 + 0.02 * n, 200.0), ("w", 2.0 + 0.1 * n, 40000.0)):
            rows.append({"photo": f"{name}{n}", "error_m": error, "seconds": 1.0, "refined_poses": [
                [0, 0, 2, 0, 0, 0, 800, best], [9000, 0, 2, 0, 0, 0, 800, best / (1 - margin)]]})
    fit = fit_confidence(rows, choices_m=(1000.0,), score_term=True)
    out = fit["leave_place_out"]
    assert out["margin+score"]["right"] >= 8 and out["margin+score"]["wrong"] == 0
    assert out["margin"]["right"] <= 2
    assert fit["logit"][2] < 0  # a higher score, a lower confidence


def test_leaving_out_a_place_judges_its_burst_by_the_other_places_only():
    """Five near-identical wrong answers from one place, with a margin no other wrong answer reaches:
    a photo judged by a fit on its own burst is withheld, the place judged by the other places is not
    (the honest count, since the split holds out places)."""
    from skyrender.training.localize_fit import leave_place_out

    margin = np.r_[np.linspace(0.2, 0.6, 10), np.linspace(0.0, 0.1, 10), np.full(5, 0.3)]
    right = np.r_[np.ones(10, bool), np.zeros(15, bool)]
    log_best = np.zeros(25)
    one_by_one = leave_place_out(margin, log_best, right, np.arange(25).astype(str), score_term=False)
    by_place = leave_place_out(margin, log_best, right, np.r_[np.arange(20).astype(str), ["P"] * 5], score_term=False)
    assert one_by_one["wrong"] == 0 and by_place["wrong"] == 5


def test_the_fov_unknown_threshold_clears_that_mode_s_wrong_training_answers_and_applies_to_its_rows_only():
    """With the fov unknown a wrong answer can win by a margin no fov-known one does: its threshold is
    the same rule on training rows localized that way, never below the fov-known one, and the
    localizer and a benchmark rescore apply it to fov-unknown answers only."""
    from skyrender.benchmarks.real_localize import rescore
    from skyrender.localizer import LocalizeParams
    from skyrender.training.localize_fit import fov_unknown_threshold

    logit = (-3.0, 20.0)  # margins 0.3 -> 0.95, 0.5 -> 1.0, 0.05 -> 0.12
    rows = [{"photo": "r", "error_m": 300.0, "best_score": 1.0, "runner_up_score": 2.0},
            {"photo": "w", "error_m": 34000.0, "best_score": 1.4, "runner_up_score": 2.0},
            {"photo": "x", "error_m": None, "best_score": 1.9, "runner_up_score": 2.0}]
    assert fov_unknown_threshold(rows, logit, 1000.0, 0.9) == pytest.approx(1.0)  # above the wrong 0.95
    assert fov_unknown_threshold(rows[::2], logit, 1000.0, 0.9) == 0.9  # never below the fov-known threshold
    params = LocalizeParams(min_confidence=0.9, min_confidence_fov_unknown=0.97)
    assert params.abstain_below(False) == 0.9 and params.abstain_below(True) == 0.97
    assert LocalizeParams(min_confidence=0.8).abstain_below(True) == 0.8  # unset: the same for both
    photo = LocalizeParams.for_photos()
    assert photo.abstain_below(True) >= photo.abstain_below(False)
    run = [dict(rows[1], status="localized", confidence=0.95, fov_mode=mode) for mode in ("known", "unknown")]
    out = rescore(run, logit, 0.9, 1000.0, 0.97)
    assert [r["status"] for r in out] == ["localized", "abstained"]


def test_the_photo_abstention_threshold_clears_every_wrong_training_answer():
    from skyrender.training.localize_fit import abstain_threshold

    conf = np.array([0.99, 0.83, 0.73, 0.12, np.nan])
    right = np.array([True, True, False, False, False])
    assert abstain_threshold(conf, right) == pytest.approx(0.75)  # above the wrong 0.73
    assert abstain_threshold(conf[[0, 1, 3]], right[[0, 1, 3]]) == 0.5  # never below 0.5
    assert abstain_threshold(np.array([0.97]), np.array([False])) == 1.0

def test_localizes_from_the_far_horizons_alone(scene, views):
    """No peak hypotheses at all (two image peaks taken): the far-horizon poses, verified
    and refined, localize view 1 (whose matched peaks lie at opposite edges of the frame)."""
    _, terrain, model = scene
    pose = views.poses[1]
    result = localize(photo_of(terrain, pose), model, 2.0, 60.0, terrain=terrain,
                      params=LocalizeParams(n_peaks=2))
    assert_localized_near(result, pose)
    assert result.stats.evaluated == 0 and result.stats.horizon_poses > 100
    # every refined candidate is kept, the answer the best of them
    refined = np.array(result.stats.refined_poses)
    assert len(refined) == result.stats.refined > 1
    best = refined[np.argmin(refined[:, 7])]
    assert np.allclose(best[:6], result.pose) and best[7] == result.stats.best_score


def test_a_search_about_to_abstain_refines_more_far_horizon_candidates_first(scene, views):
    """``escalate_refinements``: a search that would abstain refines the best far-horizon candidates
    it left unrefined, up to that many by each ranking, after the same search as without it; an
    answered search does not."""
    _, terrain, model = scene
    photo = photo_of(terrain, views.poses[1])
    runs = {n: localize(photo, model, 2.0, 60.0, terrain=terrain,
                        params=LocalizeParams(n_peaks=2, min_confidence=1.01, escalate_refinements=n,
                                              rescore_refinements=0)) for n in (0, 4)}
    assert not runs[4].localized and "escalation" in runs[4].stats.seconds and "escalation" not in runs[0].stats.seconds
    before = runs[0].stats.refined
    assert 1 <= runs[4].stats.refined - before <= 8
    assert runs[4].stats.refined_poses[:before] == runs[0].stats.refined_poses
    answered = localize(photo, model, 2.0, 60.0, terrain=terrain, params=LocalizeParams(n_peaks=2))
    assert answered.localized and "escalation" not in answered.stats.seconds


def test_a_search_still_about_to_abstain_refines_far_horizon_poses_moved_to_the_best_of_a_grid(scene, views):
    """``rescore_refinements``: a search still about to abstain after its escalation moves every kept
    far-horizon pose to the best of a grid around it and refines the best of them, distinct from the
    poses refined before: a view that a starved far-horizon search (one refinement) abstains on is
    then localized, after the same search as without it; an answered search does not pay for it."""
    _, terrain, model = scene
    starved = dict(n_peaks=2, max_horizon_refinements=1, final_refinements=1, escalate_refinements=0)
    photo = photo_of(terrain, views.poses[3])
    runs = {n: localize(photo, model, 2.0, 60.0, terrain=terrain, params=LocalizeParams(**starved, rescore_refinements=n))
            for n in (0, 6)}
    assert not runs[0].localized and "rescore" not in runs[0].stats.seconds
    before = runs[0].stats.refined
    assert runs[6].stats.refined_poses[:before] == runs[0].stats.refined_poses
    assert 1 <= runs[6].stats.refined - before <= 6 and "rescore" in runs[6].stats.seconds
    assert_localized_near(runs[6], views.poses[3])
    answered = localize(photo_of(terrain, views.poses[0]), model, 2.0, 60.0, terrain=terrain,
                        params=LocalizeParams(**starved, rescore_refinements=6))
    assert answered.localized and "rescore" not in answered.stats.seconds


def test_the_truth_refinement_diagnostic_orients_and_pins_a_camera_at_its_position(scene, views):
    """``diagnostics.truth_refine``: at a view's true position, the pan x tilt grid finds its
    orientation within the grid's half steps, and the pinned refinement fits the skyline
    without leaving the position; a wrong answer is blamed on the score only when the truth
    scores no better."""
    from dataclasses import replace

    from skyrender.diagnostics.truth_refine import PINNED_LEVELS, orientation_at, verdict

    _, terrain, _ = scene
    params = LocalizeParams()
    truth = views.poses[0].array()
    sky = render_skylines(terrain, truth, K)
    start = orientation_at(terrain, truth[0], truth[1], 2.0, K, sky, np.ones(640), params, n=3)[0]
    assert abs((start[3] - truth[3] + 180) % 360 - 180) <= 1.01 and abs(start[4] - truth[4]) <= 2.51
    pinned = refine_pose(terrain, start, K, 2.0, sky, np.ones(640), params=params.score,
                         refine=replace(params.refine, search_levels=PINNED_LEVELS))
    assert pinned.score < 0.1 and np.hypot(*(pinned.pose[:2] - truth[:2])) < 5.0
    row = {"error_m": 5000.0, "answer_score": 1.5, "pinned": {"score": 1.2}, "from_truth": {"score": 1.0, "moved_m": 2000.0}}
    assert verdict(row) == "search" and verdict({**row, "pinned": {"score": 1.6}}) == "score"
    assert verdict({**row, "error_m": 300.0}) == "right"


def test_localizes_with_unknown_field_of_view(scene, views):
    """fov=None on a 54-degree photo, between the candidate focal lengths: the far-horizon
    search picks the fov whose poses fit best (bisecting to 1.25 deg), and the focal
    length is refined with the pose."""
    _, terrain, model = scene
    pose = views.poses[4]
    result = localize(photo_of(terrain, pose, Intrinsics.from_fov(54.0, 640, 480)), model, 2.0, None, terrain=terrain)
    assert_localized_near(result, pose)
    assert result.fov == pytest.approx(54.0, abs=0.75)


def test_a_fov_given_answer_about_to_be_withheld_is_given_where_a_search_with_the_fov_unknown_agrees(scene, views):
    """The second opinion (stage 4e): with the fov given, an answer whose confidence falls short of the threshold,
    but not below ``second_opinion_from``, is searched for again with the fov unknown. Where the two best places lie
    within ``second_opinion_m`` its logit gains ``second_opinion_gain`` and it is given, the second search's place in
    the stats; where they do not, the abstention stands, with the second place kept; below the floor none is asked."""
    from dataclasses import replace

    from skyrender.localizer.confidence import agreed_confidence

    _, terrain, model = scene
    pose = views.poses[4]
    image = photo_of(terrain, pose)
    # a margin confidence below 0.75 (logistic of a margin <= 1): the threshold 0.9 withholds every answer
    params = replace(LocalizeParams(), max_hypotheses=0, fov_candidates=(60.0,), horizon_fov_step=(),
                     confidence_model="margin", margin_logit=(0.0, 1.0), min_confidence=0.9,
                     second_opinion_from=0.0, second_opinion_gain=10.0)
    alone = localize(image, model, 2.0, 60.0, terrain=terrain, params=replace(params, second_opinion_from=math.inf))
    assert not alone.localized and 0.5 < alone.confidence < 0.75 and alone.stats.second_opinion is None
    agreed = localize(image, model, 2.0, 60.0, terrain=terrain, params=params)
    assert_localized_near(agreed, pose)
    assert agreed.confidence == pytest.approx(agreed_confidence(alone.confidence, 10.0)) and agreed.confidence > 0.99
    second = agreed.stats.second_opinion
    assert second["apart_m"] < 100.0 and np.hypot(*(np.array(second["pose"][:2]) - pose.array()[:2])) < POS_TOL_M
    assert agreed.stats.seconds["second_opinion"] >= second["seconds"] > 0.0
    apart = localize(image, model, 2.0, 60.0, terrain=terrain, params=replace(params, second_opinion_m=-1.0))
    assert not apart.localized and apart.confidence == alone.confidence
    assert apart.stats.second_opinion["pose"] == second["pose"]  # the same second search, to the bit
    below = localize(image, model, 2.0, 60.0, terrain=terrain, params=replace(params, second_opinion_from=0.8))
    assert not below.localized and below.stats.second_opinion is None
    assert LocalizeParams().second_opinion_from == math.inf  # renders: never


def test_an_agreed_answer_s_logit_gains_the_fitted_gain_and_the_fit_holds_no_wrong_answer_agreed_with():
    """``agreed_confidence`` adds the gain to a confidence's logit (0 and 1 stay); ``agreement_gain`` is large where
    only right answers are agreed with, about 0 where agreement says nothing; ``fit_second_opinion`` answers an agreed
    row withheld above the floor, and never one below it or one not agreed with; a rescore applies it from a row's
    own second opinion or the run's fov-unknown row of the photo."""
    from skyrender.benchmarks.real_localize import rescore
    from skyrender.localizer.confidence import agreed_confidence
    from skyrender.training.localize_fit import agreement_gain, fit_second_opinion, second_opinion_answers

    assert agreed_confidence(0.5, 2.0) == pytest.approx(1 / (1 + math.exp(-2.0)))
    assert agreed_confidence(0.0, 5.0) == 0.0 and agreed_confidence(1.0, -5.0) == 1.0
    assert agreed_confidence(1e-300, -800.0) == 0.0  # no overflow
    rng = np.random.default_rng(0)
    z = rng.normal(0.0, 1.0, 400)
    right = rng.random(400) < 1 / (1 + np.exp(-z))
    assert agreement_gain(z, right & (rng.random(400) < 0.5), right) > 3.0
    assert abs(agreement_gain(z, rng.random(400) < 0.5, right)) < 0.6
    conf = np.array([0.97, 0.7, 0.7, 0.4])
    agree = np.array([False, True, False, True])
    assert second_opinion_answers(conf, agree, 5.0, 0.95, 0.5).tolist() == [True, True, False, False]

    def row(photo, xy, score, mode="known", truth=(0.0, 0.0)):
        return {"photo": photo, "fov_mode": mode, "truth_xy": list(truth), "seconds": 1.0,
                "refined_poses": [[*xy, 0, 0, 0, 0, 800.0, score], [50_000.0, 0, 0, 0, 0, 0, 800.0, score * 1.05]]}

    logit = (-3.0, 60.0)  # margin 1 - 1/1.05 = 0.048 -> 0.45; 1 - 1/1.1 = 0.091 -> 0.92
    known = [dict(row("a", (100.0, 0.0), 1.0), error_m=100.0), dict(row("b", (30_000.0, 0.0), 1.0), error_m=30_000.0)]
    for r in known:
        r["refined_poses"][1][7] = 1.1
    unknown = [row("a", (300.0, 0.0), 2.0, "unknown"), row("b", (80_000.0, 0.0), 2.0, "unknown")]
    fit = fit_second_opinion(known, unknown, logit, 1000.0, 0.95, 0.5)
    assert fit["agreed"] == {"right": 1, "wrong": 0} and fit["answered"]["right"] == 1 and fit["answered"]["wrong"] == 0
    second = {"from": 0.5, "gain": fit["gain"], "apart_m": 1000.0}
    runs = [dict(r, status="abstained", confidence=0.0, second_opinion=None) for r in known]
    runs[0].update(status="localized", error_m=100.0)
    unknown_runs = [dict(u, status="abstained", confidence=0.0) for u in unknown]
    wide = {"a": 800.0, "b": 800.0}  # 65 deg on 1024 px: the fov-unknown search is the second opinion's
    out = rescore(runs + unknown_runs, logit, 0.95, 1000.0, 0.95, second, wide)
    assert out[0]["status"] == "localized" and out[0]["confidence"] > 0.95 and out[1]["status"] == "abstained"
    with pytest.raises(ValueError, match="second opinion"):
        rescore(runs, logit, 0.95, 1000.0, 0.95, second, wide)  # no fov-unknown rows to take it from
    narrow = {"a": 3000.0, "b": 3000.0}  # 19 deg: beyond the fov-unknown search's reach, its rows are no second opinion
    with pytest.raises(ValueError, match="second opinion"):
        rescore(runs + unknown_runs, logit, 0.95, 1000.0, 0.95, second, narrow)
    seconds = [dict(u, fov_mode="second") for u in unknown_runs]  # real_localize --fov second: the scaled search
    out = rescore(runs + unknown_runs + seconds, logit, 0.95, 1000.0, 0.95, second, narrow)
    assert out[0]["status"] == "localized" and out[1]["status"] == "abstained"
    # a "second" row is a search with the fov unknown: rescored with that mode's threshold
    answered = [dict(u, status="localized", error_m=1.0) for u in seconds]
    out = rescore(answered, logit, 0.95, 1000.0, 0.0, None, narrow)
    assert [r["status"] for r in out] == ["localized", "localized"]


def test_a_second_opinion_searches_a_range_scaled_to_a_given_fov_the_fov_unknown_search_does_not_reach(
        scene, views, monkeypatch):
    """The second opinion's search is the fov-unknown search where that reaches the given fov (its coarse fovs less
    and plus every probe step: the photo preset's 27.5-72.5 deg), and elsewhere that search with its coarse fovs and
    steps scaled by the given fov over the middle coarse one: a 19.5-deg telephoto is searched at 13.65 / 19.5 /
    25.35 deg with probes of 1.95 and 0.975 deg. The localizer runs it so."""
    from dataclasses import replace

    from skyrender.localizer import pipeline
    from skyrender.localizer.pipeline import fov_within_reach, second_opinion_params

    photo = LocalizeParams.for_photos()
    assert photo.fov_candidates == (35.0, 50.0, 65.0) and photo.horizon_fov_step == (5.0, 2.5)
    assert fov_within_reach(photo, 27.5) and fov_within_reach(photo, 72.5) and fov_within_reach(photo, 56.8)
    assert not fov_within_reach(photo, 27.4) and not fov_within_reach(photo, 72.6)
    assert second_opinion_params(photo, 56.8) is photo
    tele = second_opinion_params(photo, 19.5)
    np.testing.assert_allclose(tele.fov_candidates, (13.65, 19.5, 25.35))
    np.testing.assert_allclose(tele.horizon_fov_step, (1.95, 0.975))
    assert replace(tele, fov_candidates=photo.fov_candidates, horizon_fov_step=photo.horizon_fov_step) == photo
    assert second_opinion_params(photo, 80.0).fov_candidates == pytest.approx((56.0, 80.0, 104.0))

    _, terrain, model = scene
    image = photo_of(terrain, views.poses[4])
    params = replace(LocalizeParams(), max_hypotheses=0, fov_candidates=(60.0,), horizon_fov_step=(),
                     confidence_model="margin", margin_logit=(0.0, 1.0), min_confidence=0.9, second_opinion_from=0.0)
    searched = []
    search_and_decide = pipeline._search_and_decide

    def spy(photo_, model_, terrain_, height, fov, prior, params_, *rest):
        searched.append((fov, params_.fov_candidates))
        return search_and_decide(photo_, model_, terrain_, height, fov, prior, params_, *rest)

    monkeypatch.setattr(pipeline, "_search_and_decide", spy)
    localize(image, model, 2.0, 60.0, terrain=terrain, params=params)
    assert searched == [(60.0, (60.0,)), (None, (60.0,))]  # reached: the fov-unknown search as it is
    searched.clear()
    localize(image, model, 2.0, 60.0, terrain=terrain, params=replace(params, fov_candidates=(30.0,)))
    assert searched == [(60.0, (30.0,)), (None, (60.0,))]  # 30 deg never comes to 60: scaled to it


def test_far_horizon_poses_are_moved_before_ranking_with_the_fov_given_and_not_unknown_where_so_set(scene, views):
    """``horizon_rerank`` moves far-horizon poses to the best of a grid around them before they are ranked; with
    ``rerank_fov_unknown`` False only when the fov is given (the photo preset re-ranks with the fov unknown too).
    The view is localized either way."""
    from dataclasses import replace

    _, terrain, model = scene
    pose = views.poses[4]
    params = replace(LocalizeParams(), max_hypotheses=0, horizon_rerank=4, rerank_grid=3, rerank_half_m=150.0,
                     rerank_stride=16, rerank_fov_unknown=False, fov_candidates=(60.0,), horizon_fov_step=())
    given = localize(photo_of(terrain, pose), model, 2.0, 60.0, terrain=terrain, params=params)
    unknown = localize(photo_of(terrain, pose), model, 2.0, None, terrain=terrain, params=params)
    assert given.stats.seconds.get("rerank", 0.0) > 0.0 and "rerank" not in unknown.stats.seconds
    for result in (given, unknown):
        assert_localized_near(result, pose)


def test_with_the_fov_unknown_the_re_ranking_moves_only_its_own_number_of_poses_by_each_ranking(scene, views,
                                                                                                 monkeypatch):
    """``horizon_rerank_fov_unknown``: with the fov unknown the re-ranking moves the best that many poses by each
    ranking instead of ``horizon_rerank`` (the rest left out); with the fov given ``horizon_rerank`` as before. The
    view is localized either way. The photo preset moves 300 by each ranking with the fov unknown, all with it given."""
    from dataclasses import replace

    from skyrender.localizer import pipeline

    moved, rerank = [], pipeline.rerank_far_horizon

    def counted(*args, **kwargs):
        out = rerank(*args, **kwargs)
        moved.append(len(out[0]))
        return out

    monkeypatch.setattr(pipeline, "rerank_far_horizon", counted)
    _, terrain, model = scene
    pose = views.poses[4]
    params = replace(LocalizeParams(), max_hypotheses=0, horizon_rerank=6, horizon_rerank_fov_unknown=1, rerank_grid=3,
                     rerank_half_m=150.0, rerank_stride=16, fov_candidates=(60.0,), horizon_fov_step=())
    assert_localized_near(localize(photo_of(terrain, pose), model, 2.0, 60.0, terrain=terrain, params=params), pose)
    assert len(moved) == 1 and 6 <= moved[0] <= 12
    moved.clear()
    assert_localized_near(localize(photo_of(terrain, pose), model, 2.0, None, terrain=terrain, params=params), pose)
    assert moved and all(1 <= n <= 2 for n in moved)
    photo = LocalizeParams.for_photos()
    assert photo.horizon_rerank_fov_unknown == 300 and photo.horizon_rerank >= 10_000


def test_the_re_ranking_renders_as_many_columns_on_a_photo_of_any_width():
    """The photo preset's re-ranking renders every 32nd column of a 1,024-wide CH1 photo; a 12 MP phone photo (4,032
    columns) as many columns, not four times as many; without a stride of its own, the verification's."""
    from dataclasses import replace

    from skyrender.localizer.pipeline import rerank_columns

    photo = LocalizeParams.for_photos()
    assert [rerank_columns(photo, w) for w in (1024, 4032, 640, 16)] == [32, 126, 20, 1]
    assert rerank_columns(replace(photo, rerank_stride=None), 4032) == photo.verify_stride


def test_a_wide_photo_is_searched_on_its_skyline_reduced_and_answered_in_its_own_pixels(scene, views):
    """``search_width`` (the photo preset's: 1,024): a photo twice as wide as it is searched on its skyline reduced to
    that many columns — the reduced skyline is the one the same view rendered that wide has (within a tenth of a
    pixel where the skyline is smooth), NaN columns stay NaN — and localized to the same place as the
    narrower photo, with its intrinsics, skyline and rendered skyline in its own pixels."""
    from dataclasses import replace

    from skyrender.localizer.pipeline import reduce_skyline
    from skyrender.render import render_skylines

    _, terrain, model = scene
    pose = views.poses[4]
    wide = Intrinsics.from_fov(60.0, 1280, 960)
    sky_wide = render_skylines(terrain, pose.array(), wide)
    sky_narrow = render_skylines(terrain, pose.array(), K)
    rows, w, width, height = reduce_skyline(sky_wide, np.ones(1280), 1280, 960, 640)
    assert (width, height) == (640, 480) and np.array_equal(w, np.ones(640))
    smooth = np.abs(np.diff(sky_narrow, prepend=sky_narrow[0])) < 1.0
    assert np.nanmedian(np.abs(rows - sky_narrow)[smooth]) < 0.1
    holes = sky_wide.copy()
    holes[100:110] = np.nan
    rows, _, _, _ = reduce_skyline(holes, np.ones(1280), 1280, 960, 640)
    assert np.isnan(rows[50:55]).all() and np.isfinite(rows[:50]).all() and np.isfinite(rows[55:]).all()

    params = replace(LocalizeParams(), max_hypotheses=0, fov_candidates=(60.0,), horizon_fov_step=(), search_width=640)
    result = localize(photo_of(terrain, pose, wide), model, 2.0, 60.0, terrain=terrain, params=params)
    assert_localized_near(result, pose)
    assert result.stats.searched_width == 640 and (result.intrinsics.width, result.intrinsics.height) == (1280, 960)
    assert result.intrinsics.fov == pytest.approx(result.fov)
    assert result.image_skyline.shape == result.rendered_skyline.shape == (1280,)
    assert np.nanmedian(np.abs(result.rendered_skyline - result.image_skyline)) < 2.0
    assert all(r[6] == pytest.approx(wide.f_px, rel=0.05) for r in result.stats.refined_poses)


def test_a_telephoto_range_searched_apart_when_the_fov_is_unknown():
    """The photo preset's unknown-fov search never comes below 30 deg; the telephoto range
    (``telephoto_fovs``, an option) searches 14 and 21 deg apart, probing by ratios: a 200 mm lens
    (35 mm frame, 10.3 deg, just outside) ends within 11 % of a fov tried, CH1's 14.4-deg telephotos
    and an 85 mm lens (23.9 deg) within 6 %. The probes stay within the range widened by the first
    ratio step. Its candidates are refined on a budget of their own: a wrong place fits a narrow
    view better than the right place fits a wide one before refinement, and would otherwise take
    every refinement."""
    from dataclasses import replace

    from skyrender.localizer.params import PHOTO_TELEPHOTO_FOVS, PHOTO_TELEPHOTO_STEPS
    from skyrender.localizer.pipeline import _Candidate, _narrow_fov, _next_to_refine

    params = replace(LocalizeParams.for_photos(), telephoto_fovs=PHOTO_TELEPHOTO_FOVS,
                     telephoto_fov_step=PHOTO_TELEPHOTO_STEPS)
    for true_fov, within in ((10.3, 1.11), (14.4, 1.06), (19.5, 1.06), (23.9, 1.06)):
        tried = []

        def verify_at(fov, true_fov=true_fov, tried=tried):  # the best fit where the fov is right
            tried.append(fov)
            verified[fov] = (0.0, None, np.array([abs(math.log(fov / true_fov))]), None)

        verified = {}
        for fov in PHOTO_TELEPHOTO_FOVS:
            verify_at(fov)
        _narrow_fov(verified, verify_at, PHOTO_TELEPHOTO_STEPS, ratio=True)
        best = min(verified, key=lambda f: verified[f][2][0])
        assert abs(math.log(best / true_fov)) <= math.log(within), (true_fov, sorted(verified))
        widen = 1.0 + PHOTO_TELEPHOTO_STEPS[0]
        assert PHOTO_TELEPHOTO_FOVS[0] / widen - 1e-9 <= min(tried) and max(tried) <= PHOTO_TELEPHOTO_FOVS[-1] * widen + 1e-9
    pose = np.zeros(6)
    wide = [_Candidate(pose, 900.0, 2.0 + i, 2.0 + i, None) for i in range(20)]
    narrow = [_Candidate(pose, 3000.0, 1.0 + i / 100, 1.0 + i / 100, None, lens=1) for i in range(20)]
    picked = _next_to_refine(wide + narrow, 8, params, budgeted=False, peaks=False)
    assert sum(c.lens == 0 for c in picked) == 8 and sum(c.lens == 1 for c in picked) == params.telephoto_refinements


def test_with_the_fov_unknown_the_other_coarse_fovs_candidates_are_refined_on_a_budget_of_their_own(scene, views,
                                                                                                 monkeypatch):
    """``other_fov_refinements`` (an option): with the fov unknown, the far-horizon candidates of the coarse fovs other
    than the two best-fitting join as lens 2, and that many by each ranking are refined beside the others, so that the
    answer's margin is taken against places found at other focal lengths too. With the fov given there are no other
    fovs; off (0), nothing joins. The view is localized every way."""
    from dataclasses import replace

    import skyrender.localizer.pipeline as pipeline
    from skyrender.localizer.pipeline import _Candidate, _next_to_refine

    _, terrain, model = scene
    pose = views.poses[4]
    refined_lenses = []
    refine = pipeline._refine

    def recording(cand, search):
        refined_lenses.append(cand.lens)
        return refine(cand, search)

    monkeypatch.setattr(pipeline, "_refine", recording)
    params = replace(LocalizeParams(), max_hypotheses=0, fov_candidates=(45.0, 60.0, 75.0), horizon_fov_step=(),
                     other_fov_refinements=1)
    for fov, option, lens_2 in ((None, 1, True), (None, 0, False), (60.0, 1, False)):
        refined_lenses.clear()
        result = localize(photo_of(terrain, pose), model, 2.0, fov, terrain=terrain,
                          params=replace(params, other_fov_refinements=option))
        assert_localized_near(result, pose)
        assert (2 in refined_lenses) == lens_2, (fov, option, refined_lenses)
        assert refined_lenses.count(2) <= 2 * option
    same = np.zeros(6)
    found = [_Candidate(same, 900.0, 2.0 + i, 2.0 + i, None) for i in range(20)]
    other = [_Candidate(same, 600.0, 1.0 + i / 100, 3.0 - i / 100, None, lens=2) for i in range(20)]
    picked = _next_to_refine(found + other, 8, replace(params, other_fov_refinements=2), budgeted=False, peaks=False)
    # the two best by each ranking: other[0], other[1] by score, other[19], other[18] by the second ranking
    assert sum(c.lens == 0 for c in picked) == 8 and [c for c in picked if c.lens == 2] == [other[i] for i in (0, 1, 18, 19)]


@pytest.mark.parametrize("terms, roll", [(2, math.inf), (3, math.inf), (2, 8.0)])
def test_horizon_costs_in_blocks_of_centres_are_the_whole_arrays_to_the_bit(monkeypatch, terms, roll):
    """:func:`horizon_costs` works through the centres in blocks (on all cores): any block size
    gives the costs and fitted offsets of one block holding every centre, to the bit."""
    import scipy.fft

    from skyrender.localizer import horizon_search

    rng = np.random.default_rng(5)
    n_bins, bin_deg = 360, 1.0
    P = np.cumsum(rng.normal(0, 0.3, (301, n_bins)), axis=1).astype(np.float32)
    spectra = scipy.fft.rfft(P, axis=1), scipy.fft.rfft(P * P, axis=1)
    bins = np.arange(-25, 26)
    elevation, weights = rng.normal(1.0, 0.5, len(bins)), rng.uniform(0.1, 1.0, len(bins))
    flat = rng.choice(P.size, 50, replace=False)
    out = {}
    for rows in (10 ** 6, 64, 7):
        monkeypatch.setattr(horizon_search, "COST_BLOCK_ROWS", rows)
        cost, offset_at = horizon_search.horizon_costs(spectra, n_bins, bins, elevation, weights, bin_deg, terms, roll)
        out[rows] = (cost, offset_at(flat))
    for rows in (64, 7):
        assert np.array_equal(out[rows][0], out[10 ** 6][0]) and np.array_equal(out[rows][1], out[10 ** 6][1])


@pytest.mark.parametrize("terms, roll", [(2, math.inf), (3, math.inf), (2, 8.0)])
def test_the_best_horizon_fits_kept_block_by_block_are_those_of_the_whole_costs_to_the_bit(monkeypatch, terms, roll):
    """:func:`best_horizon_fits` keeps each block of centres' best fits instead of storing every
    cost: for any block size and k (ties in the costs included) it gives the flat indices, in
    order, the costs and the offsets that :func:`smallest` and ``offset_at`` give on the whole
    arrays of :func:`horizon_costs`."""
    import scipy.fft

    from skyrender.localizer import horizon_search

    rng = np.random.default_rng(6)
    n_bins, bin_deg = 360, 1.0
    P = np.cumsum(rng.normal(0, 0.3, (301, n_bins)), axis=1).astype(np.float32)
    P[40] = P[41]  # two centres with one horizon: tied costs
    spectra = scipy.fft.rfft(P, axis=1), scipy.fft.rfft(P * P, axis=1)
    bins = np.arange(-25, 26)
    elevation, weights = rng.normal(1.0, 0.5, len(bins)), rng.uniform(0.1, 1.0, len(bins))
    cost, offset_at = horizon_search.horizon_costs(spectra, n_bins, bins, elevation, weights, bin_deg, terms, roll)
    for k in (1, 50, 700, P.size + 3):
        expected = horizon_search.smallest(cost, k)
        for rows in (10 ** 6, 64, 7):
            monkeypatch.setattr(horizon_search, "COST_BLOCK_ROWS", rows)
            flat, best, offset = horizon_search.best_horizon_fits(spectra, n_bins, bins, elevation, weights, bin_deg,
                                                                  k, terms, roll)
            np.testing.assert_array_equal(flat, expected)
            assert np.array_equal(best, cost.ravel()[expected]) and np.array_equal(offset, offset_at(expected))
    assert len(horizon_search.best_horizon_fits(spectra, n_bins, bins, elevation, weights, bin_deg, 0, terms,
                                                roll)[0]) == 0


def test_horizon_costs_with_a_bounded_roll_equal_a_direct_fit_with_the_slope_held():
    """The far-horizon cost of every (centre, azimuth) with the slope term held within a roll
    bound (the photo preset's) equals a direct weighted least-squares fit of the offset with the
    slope at the bound, where the free fit's slope lies beyond it, and the free fit's elsewhere."""
    import scipy.fft

    from skyrender.localizer.horizon_search import horizon_costs

    rng = np.random.default_rng(3)
    n_bins, bin_deg = 360, 1.0
    P = np.cumsum(rng.normal(0, 0.3, (4, n_bins)), axis=1).astype(np.float32)
    P -= np.linspace(0, 1, n_bins)[None] * (P[:, -1:] - P[:, :1])  # periodic
    spectra = scipy.fft.rfft(P, axis=1), scipy.fft.rfft(P * P, axis=1)
    bins = np.arange(-20, 21)
    alpha = np.radians(bins * bin_deg)
    w = rng.uniform(0.2, 1.0, len(bins))
    # the photo: horizon 2 seen at azimuth 100 with a roll of 12 deg and an offset
    e = P[2, (bins + 100) % n_bins] - 1.5 - np.tan(np.radians(12.0)) * np.degrees(alpha)
    free, _ = horizon_costs(spectra, n_bins, bins, e, w, bin_deg, terms=2)
    held, offset_at = horizon_costs(spectra, n_bins, bins, e, w, bin_deg, terms=2, max_swing_deg=5.0)
    assert free[2, 100] < 1e-4 and held[2, 100] > 0.01
    bound = np.tan(np.radians(5.0)) * 180 / np.pi
    for c, p in ((2, 100), (0, 37), (3, 250)):
        d = P[c, (bins + p) % n_bins] - e
        X = np.column_stack([np.ones_like(alpha), alpha])
        beta = np.linalg.solve(X.T @ (X * w[:, None]), X.T @ (w * d))
        slope = np.clip(beta[1], -bound, bound)
        offset = np.sum(w * (d - slope * alpha)) / w.sum()
        direct = np.sum(w * (d - offset - slope * alpha) ** 2) / w.sum()
        assert held[c, p] == pytest.approx(direct, rel=1e-3, abs=1e-5)
        assert offset_at(np.array([c * n_bins + p]))[0] == pytest.approx(offset, rel=1e-3, abs=1e-4)
    assert np.all(held >= free - 1e-5)


@pytest.mark.parametrize("terms", [2, 3])
def test_horizon_costs_on_a_narrow_window_equal_a_direct_float64_fit(terms):
    """A window of the skyline 18 deg wide and off the optical axis (the right half of a 35 deg
    view) with horizons tens of degrees high: every cost near the best is the direct float64
    weighted least-squares fit's to 1e-4 deg^2, and none is negative. In the raw basis 1, alpha,
    alpha^2 the float32 correlations cancelled to errors of 0.02 deg^2 (negative costs), so the
    best 200 of a window were noise when the right match costs 0.002."""
    import scipy.fft

    from skyrender.localizer.horizon_search import horizon_costs, smallest

    rng = np.random.default_rng(11)
    n_bins, bin_deg = 360, 1.0
    P = 15.0 + np.cumsum(rng.normal(0, 0.4, (400, n_bins)), axis=1)
    P -= np.linspace(0, 1, n_bins)[None] * (P[:, -1:] - P[:, :1])  # periodic
    P = P.astype(np.float32)
    spectra = scipy.fft.rfft(P, axis=1), scipy.fft.rfft(P * P, axis=1)
    bins = np.arange(2, 20)
    alpha = np.radians(bins * bin_deg)
    w = rng.uniform(0.3, 1.0, len(bins))
    e = P[7, (bins + 123) % n_bins] - 4.0 + 0.3 * alpha + rng.normal(0, 0.03, len(bins))  # horizon 7 at azimuth 123
    cost, _ = horizon_costs(spectra, n_bins, bins, e, w, bin_deg, terms=terms)
    X = np.column_stack([np.ones_like(alpha), alpha, alpha ** 2])[:, :terms]
    flat = np.concatenate([smallest(cost, 200), rng.choice(cost.size, 200, replace=False)])
    centre, azimuth = np.divmod(flat, n_bins)
    d = P[centre][np.arange(len(flat))[:, None], (bins[None] + azimuth[:, None]) % n_bins].astype(np.float64) - e
    sw = np.sqrt(w)
    coef = np.linalg.lstsq(X * sw[:, None], (d * sw).T, rcond=None)[0]
    direct = (((d - (X @ coef).T) ** 2) * w).sum(axis=1) / w.sum()
    np.testing.assert_allclose(cost.ravel()[flat], direct, rtol=1e-3, atol=1e-4)
    assert cost.min() > -1e-4 and smallest(cost, 1)[0] == 7 * n_bins + 123


def test_the_smallest_horizon_costs_are_a_full_sort_s_first_k_ties_by_index():
    from skyrender.localizer.horizon_search import smallest

    rng = np.random.default_rng(8)
    cost = np.round(rng.normal(size=(500, 36)), 1).astype(np.float32)  # many ties
    cost[rng.integers(0, 500, 20), rng.integers(0, 36, 20)] = -9.0
    flat = cost.ravel()
    for k in (1, 7, 200, 499, 500, 501, cost.size + 5):
        expected = np.lexsort((np.arange(flat.size), flat))[: min(k, flat.size)]
        np.testing.assert_array_equal(smallest(cost, k), expected)
    assert len(smallest(cost, 0)) == 0


def test_an_interrupted_benchmark_run_keeps_its_finished_rows_and_loads_no_model_for_them():
    from types import SimpleNamespace

    from skyrender.benchmarks.real_localize import run

    items = [SimpleNamespace(key="ch1/DSCF3435_01024", lat=46.1, lon=7.6),
             SimpleNamespace(key="ch1/DSCF3436_01024", lat=46.1, lon=7.6)]
    done = {(it.key, m): {"photo": it.key, "fov_mode": m} for it in items for m in ("known", "unknown")}
    del done[items[1].key, "unknown"]  # not asked for: the fov-unknown mode runs on every 2nd photo only
    new_rows = []
    rows = run(items, ["known", "unknown"], progress=False, unknown_every=2, done=done, on_row=new_rows.append)
    assert [(r["photo"], r["fov_mode"]) for r in rows] == [(items[0].key, "known"), (items[0].key, "unknown"),
                                                           (items[1].key, "known")]
    assert new_rows == []  # nothing localized again
