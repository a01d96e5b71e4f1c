"""Fit the real-photo confidence of the localizer on the CH1 photos of the training side.

``python -m skyrender.training.localize_fit [--limit N] [--from-rows | --extend]``

Each CH1 photo of the training and dev sides (``experiments/photos/split.json``) is localized with
:meth:`LocalizeParams.for_photos` and no abstention (``min_confidence`` 0), its skyline extracted by
the photo preset's extractor, the fov known. Per photo the margin m = 1 - best / runner-up refined
score is recorded with whether the answer lies within 1 km of the true position; a logistic P(within
1 km) = 1 / (1 + exp(-(a + b m))) is fitted by maximum likelihood (scipy), its abstention threshold
set (:func:`abstain_threshold`). ``--score-term`` adds the log best score s (px at 1024 wide): P = 1
/ (1 + exp(-(a + b m + c ln s))). It is not the default: a right answer fits better than a wrong
one, margin for margin, on the training photos, but how well any answer fits depends on the place,
and judged a place at a time (:func:`leave_place_out`, printed and written with every fit) it
answers 40 right and 5 wrong against the margin's 39 and 5; on the validation side, run once, it
answered 3 photos 2-54 km wrong (``experiments/ch1/score-term/``). ``--part-margin`` adds the
answer's smallest part margin h (:func:`~skyrender.localizer.confidence.answer_part_margin`: its margin
over the other refined places on each half of the skyline): P = 1 / (1 + exp(-(a + b m + d h))). A
look-alike that wins the whole skyline on one half loses on the other; on the training photos it kept
36 right answers above the threshold against the margin's 32, leave place out 39 right / 3 wrong
against 39 / 5 (``experiments/ch1/split-half/``), but on the validation side, rescored once, it
answered 3 more photos, one of them 54 km wrong at 0.92 (``experiments/ch1/part-margin/``): an
option, not the shipped fit. The runner-up is the best refined
pose farther than D from the answer; D is chosen from :data:`RUNNER_UP_CHOICES_M` as the one whose
fit keeps the most right answers above its threshold (a runner-up 1-3 km away often sees the same
skyline from the same valley, and is no evidence against the answer; ``--runner-up-choices``, not
the default: the 3 km it chose did not hold on the validation side). Fit, D and rows go to
``skyrender/localizer/photo_confidence.json``, which the photo preset reads; the localization rows
(refined poses, truth) to ``experiments/ch1/confidence-train-rows.json``, from which ``--from-rows``
refits without localizing. With ``--fov-unknown-rows`` (``real_localize --side train --fov unknown --no-abstain``
runs' JSON; ``make fit-photo-confidence`` passes all 73 training-side photos localized by the shipped fov-unknown
search: the 41 of ``experiments/ch1/rerank-cut-fov-unknown/`` and the 32 of ``experiments/ch1/mode-agreement/``) the
fov-unknown mode gets a threshold of its own by the same rule
(:func:`fov_unknown_threshold`). With ``--second-opinion-rows`` (fov-unknown runs of the same training photos as
the rows) the second opinion is fitted (:func:`fit_second_opinion`): how much an answer's logit gains where a search
with the fov unknown ends within 1 km of it (``LocalizeParams.second_opinion_from``). The validation side is never
used here.
"""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize

from ..benchmarks.real_localize import (
    apart_m,
    log_best_of,
    logit_text,
    margin_of,
    model_overrides,
    places_of,
    run,
    second_search_rows,
    with_part_margins,
)
from ..datasets.real_photos import DEFAULT_PHOTOS, REPO, items_on_side
from ..evaluate import git_commit
from ..localizer import LocalizeParams
from ..localizer.confidence import PHOTO_CONFIDENCE_FILE, margin_logistic, uses_part_margin

RIGHT_M = 1000.0
#: The runner-up distances tried by ``--runner-up-choices`` (m): the one keeping most right training
#: answers above its threshold is taken. Not the default: on the training side 3 km kept 20 of 22 right
#: answers (1 km: 15), but on the validation side its fit answered a photo 61 km wrong at 0.90 (and
#: one 1.2 km off) where the 1 km fit answers none wrong (experiments/ch1/bench-real-validation-poses*).
RUNNER_UP_CHOICES_M = (1000.0, 1500.0, 2000.0, 3000.0, 5000.0)
#: The runner-up distance of the shipped fit (m).
RUNNER_UP_M = 1000.0
TRAINING_ROWS_FILE = os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")


def _validation_keys() -> list[str]:
    return [it.key for it in items_on_side("validation")]


def fit_logistic(features: np.ndarray, right: np.ndarray, ridge: float = 1e-3) -> tuple[float, ...]:
    """(a, b, ...) maximising the likelihood of ``right`` (bool) under logistic(a + b f1 + c f2 ...)
    of the (n, k) ``features`` (or (n,): one), with a small ridge on the slopes (separable data
    would send them to infinity)."""
    x = np.c_[np.ones(len(right)), np.asarray(features, np.float64).reshape(len(right), -1)]
    start = np.r_[0.0, 1.0, np.zeros(x.shape[1] - 2)]

    def loss(p):
        z = x @ p
        return float(np.sum(np.logaddexp(0.0, z) - right * z) + ridge * np.sum(p[1:] ** 2))

    return tuple(float(v) for v in minimize(loss, start, method="Nelder-Mead",
                                            options={"xatol": 1e-6, "fatol": 1e-9, "maxiter": 8000}).x)


def abstain_threshold(confidence: np.ndarray, right: np.ndarray, floor: float = 0.5, step: float = 0.05) -> float:
    """The photo preset's abstention threshold, from the training photos only: above the most
    confident wrong answer (rounded up to ``step``), and never below ``floor`` (an answer must
    be more likely right than wrong)."""
    wrong = confidence[~right.astype(bool) & np.isfinite(confidence)]
    top = float(wrong.max()) if len(wrong) else 0.0
    return float(min(1.0, max(floor, np.ceil((top + 1e-9) / step) * step)))


def rows_right(rows: list[dict]) -> np.ndarray:
    """(n,) bool: each benchmark row's answer within :data:`RIGHT_M` of the truth (no answer: wrong)."""
    return np.array([(r.get("error_m") if r.get("error_m") is not None else np.inf) <= RIGHT_M for r in rows])


def confidences(margin: np.ndarray, log_best: np.ndarray, logit: tuple, part: np.ndarray | None = None) -> np.ndarray:
    """The photo confidence of each ``margin``, log best score (:func:`real_localize.log_best_of`) and
    part margin (``part``; None: 0) under ``logit`` (a, b), (a, b, c) or (a, b, c, d) (NaN: no pose,
    confidence 0)."""
    part = np.zeros(len(margin)) if part is None else np.asarray(part, np.float64)
    ok = np.isfinite(margin) & np.isfinite(log_best) & np.isfinite(part)
    return np.where(ok, margin_logistic(np.nan_to_num(margin), logit, np.nan_to_num(log_best), np.nan_to_num(part)), 0.0)


def fit_at(margin: np.ndarray, log_best: np.ndarray, right: np.ndarray, score_term: bool = False) -> dict:
    """The logistic of ``margin`` and, with ``score_term``, the log best score ``log_best`` (NaN:
    no pose, confidence 0) for ``right`` (bool), its training confidences and abstention threshold."""
    ok = np.isfinite(margin) & np.isfinite(log_best)
    features = np.c_[margin, log_best] if score_term else margin[:, None]
    logit = fit_logistic(features[ok], right[ok].astype(float))
    confidence = confidences(margin, log_best, logit)
    return {"logit": logit, "margin": margin, "confidence": confidence, "threshold": abstain_threshold(confidence, right)}


def leave_place_out(margin: np.ndarray, log_best: np.ndarray, right: np.ndarray, places: np.ndarray,
                    score_term: bool = True) -> dict:
    """Each place's photos judged by the fit and threshold (:func:`fit_at`) of the other places: how
    many right and how many wrong answers (> :data:`RIGHT_M` off) would be given, out of how many
    right. Places, not photos, are held out, as the split holds them out: a place's photos come in
    bursts of near-identical views, and a photo judged by a fit on its own burst looks safer than it
    is (the score term, one photo at a time: 39 right and 1 wrong against the margin's 32 and 1; a
    place at a time: 40 and 5 against 39 and 5)."""
    answered = np.zeros(len(right), bool)
    for place in np.unique(places):
        held = places == place
        fit = fit_at(margin[~held], log_best[~held], right[~held], score_term)
        answered[held] = confidences(margin[held], log_best[held], fit["logit"]) >= fit["threshold"]
    return {"right": int(np.sum(answered & right)), "wrong": int(np.sum(answered & ~right)), "of": int(right.sum())}


def part_margins_of(rows: list[dict]) -> np.ndarray:
    """(n,) each row's ``part_margin`` (NaN: none; :func:`real_localize.with_part_margins` gives them)."""
    return np.array([np.nan if r.get("part_margin") is None else float(r["part_margin"]) for r in rows])


def fit_confidence(rows: list[dict], choices_m=RUNNER_UP_CHOICES_M, score_term: bool = False,
                   part_term: bool = False) -> dict:
    """The photo confidence fitted on benchmark ``rows`` (:func:`real_localize.run`): for each
    runner-up distance in ``choices_m`` (m) the logistic of the margin (and, with ``score_term``, of
    the log best score; with ``part_term``, of the answer's smallest part margin, the rows'
    ``part_margin``) and its threshold (:func:`fit_at`); the distance whose fit keeps the most
    right answers above its threshold is taken (ties: the nearest). With it, the leave-place-out
    counts of the margin alone and of margin and the second cue (:func:`leave_place_out`, places from
    ``experiments/photos/split.json``). Returns what ``photo_confidence.json`` holds, less the commits;
    a part-margin fit's logit is written (a, b, 0, d), as :func:`~skyrender.localizer.confidence.margin_logistic` reads it."""
    right = rows_right(rows)
    log_best = np.array([log_best_of(r) for r in rows])
    second = part_margins_of(rows) if part_term else log_best
    place_of, _ = places_of([])
    places = np.array([place_of.get(r["photo"], r["photo"]) for r in rows])
    fits = {d: fit_at(np.array([margin_of(r, d) for r in rows]), second, right, score_term or part_term)
            for d in choices_m}
    kept = {d: int(np.sum((fit["confidence"] >= fit["threshold"]) & right)) for d, fit in fits.items()}
    runner_up_m = max(choices_m, key=lambda d: (kept[d], -d))
    fit = fits[runner_up_m]
    logit = list(fit["logit"])
    if part_term:
        logit = [logit[0], logit[1], 0.0, logit[2]]
    cue = "part" if part_term else "score"
    return {"logit": logit, "min_confidence": fit["threshold"], "runner_up_m": float(runner_up_m),
            "right_m": RIGHT_M, "photos": len(rows), "right": int(right.sum()),
            "kept_by_runner_up_m": {str(int(d)): kept[d] for d in choices_m},
            "leave_place_out": {name: leave_place_out(fit["margin"], second, right, places, term)
                                for name, term in (("margin", False), (f"margin+{cue}", True))},
            "rows": [{"photo": r["photo"], "margin": m, "log_best": lb, "part_margin": r.get("part_margin"),
                      "error_m": r.get("error_m"), "seconds": r["seconds"]}
                     for r, m, lb in zip(rows, fit["margin"], log_best)]}


#: With the fov given, an answer withheld with a confidence of at least this asks the second opinion (a search with
#: the fov unknown; ``LocalizeParams.second_opinion_from``): an answer more likely right than wrong by its own margin.
#: Below it no training answer that the second opinion agreed with was right where withheld... and the second search
#: costs a fov-unknown search's time (experiments/ch1/mode-agreement/).
SECOND_OPINION_FROM = 0.5
#: The two searches agree where their best places lie within this (m) of each other.
SECOND_OPINION_M = 1000.0


def agreement_gain(logit_z: np.ndarray, agree: np.ndarray, right: np.ndarray, ridge: float = 1e-3) -> float:
    """The gain g maximising the likelihood of ``right`` under logistic(z + g [agree]), the logits ``logit_z`` of the
    margin fit held: what the second opinion's agreement adds to an answer's logit. The same small ridge as
    :func:`fit_logistic` (on training photos where no wrong answer is agreed with, it alone bounds g)."""
    from scipy.optimize import minimize_scalar

    z, a, y = (np.asarray(v, np.float64) for v in (logit_z, agree, right))

    def loss(g):
        t = z + g * a
        return float(np.sum(np.logaddexp(0.0, t) - y * t) + ridge * g * g)

    return float(minimize_scalar(loss, bounds=(-50.0, 50.0), method="bounded", options={"xatol": 1e-6}).x)


def second_opinion_answers(confidence: np.ndarray, agree: np.ndarray, gain: float, threshold: float,
                           floor: float = SECOND_OPINION_FROM) -> np.ndarray:
    """(n,) bool: the answers given with the second opinion: at or above ``threshold`` on their own, or withheld
    with at least ``floor`` and agreed with, their confidence with the ``gain`` (:func:`agreed_confidence`)
    reaching the threshold."""
    from ..localizer.confidence import agreed_confidence

    agreed = np.array([agreed_confidence(float(c), gain) for c in confidence])
    return (confidence >= threshold) | ((confidence >= floor) & agree & (agreed >= threshold))


def fit_second_opinion(rows: list[dict], unknown_rows: list[dict], logit: tuple, runner_up_m: float,
                       threshold: float, floor: float = SECOND_OPINION_FROM) -> dict:
    """The second opinion fitted on training rows: ``rows`` (fov given, :func:`fit_confidence`'s) and
    ``unknown_rows`` (the same photos searched with the fov unknown, ``real_localize --fov unknown --no-abstain``:
    what the second search gives them, to the bit). The gain of an agreed answer's logit (:func:`agreement_gain`,
    the margin fit ``logit`` held), what it answers on the training rows at ``threshold``, and the same judged a place
    at a time (the margin fit, its threshold and the gain fitted on the other places). Rows without a
    fov-unknown row are left out."""
    unknown = {r["photo"]: r for r in unknown_rows}
    rows = [r for r in rows if r["photo"] in unknown]
    right = rows_right(rows)
    margin = np.array([margin_of(r, runner_up_m) for r in rows])
    agree = np.array([apart_m(r, unknown[r["photo"]]) <= SECOND_OPINION_M for r in rows])
    z = np.where(np.isfinite(margin), margin_logistic_logit(np.nan_to_num(margin), logit), -np.inf)
    confidence = 1.0 / (1.0 + np.exp(-z))  # margin_logistic's, to the bit; 0 without a pose
    gain = agreement_gain(z[np.isfinite(z)], agree[np.isfinite(z)], right[np.isfinite(z)])
    given = second_opinion_answers(confidence, agree, gain, threshold, floor)
    place_of, _ = places_of([])
    places = np.array([place_of.get(r["photo"], r["photo"]) for r in rows])
    held_given = np.zeros(len(rows), bool)
    for place in np.unique(places):
        held = places == place
        fit = fit_at(margin[~held], np.zeros((~held).sum()), right[~held])
        z_other = margin_logistic_logit(np.nan_to_num(margin[~held]), fit["logit"])
        g = agreement_gain(z_other, agree[~held], right[~held])
        c_held = confidences(margin[held], np.zeros(held.sum()), fit["logit"])
        held_given[held] = second_opinion_answers(c_held, agree[held], g, fit["threshold"], floor)
    alone = confidence >= threshold
    return {"from": floor, "gain": gain, "apart_m": SECOND_OPINION_M, "photos": len(rows),
            "agreed": {"right": int((agree & right).sum()), "wrong": int((agree & ~right).sum())},
            "asked": int(((confidence >= floor) & ~alone).sum()),
            "answered": {"right": int((given & right).sum()), "wrong": int((given & ~right).sum()),
                         "alone_right": int((alone & right).sum()), "alone_wrong": int((alone & ~right).sum())},
            "leave_place_out": {"right": int((held_given & right).sum()), "wrong": int((held_given & ~right).sum())}}


def margin_logistic_logit(margin: np.ndarray, logit: tuple) -> np.ndarray:
    """The logit a + b m of the margin fit (a, b) at ``margin``."""
    return logit[0] + logit[1] * np.asarray(margin, np.float64)


def fov_unknown_threshold(rows: list[dict], logit: tuple, runner_up_m: float, floor: float) -> float:
    """The abstention threshold with the fov unknown: :func:`abstain_threshold` (the same rule) on
    training rows localized that way, scored with the fov-known fit ``logit``; never below ``floor``
    (the fov-known threshold). A fov-unknown search tries 7 focal lengths, and its wrong answers
    can win by margins the fov-known ones never do."""
    confidence = confidences(np.array([margin_of(r, runner_up_m) for r in rows]),
                             np.array([log_best_of(r) for r in rows]), logit,
                             part_margins_of(rows) if uses_part_margin(logit) else None)
    return max(floor, abstain_threshold(confidence, rows_right(rows)))


def fov_unknown_report(name: str, rows: list[dict], logit: tuple, runner_up_m: float, floor: float,
                       top: int = 14) -> str:
    """A run of fov-unknown rows against the fit's rule (:func:`fov_unknown_threshold`): the best place within
    100 m / 250 m / 1 km, the threshold and what it answers, the three most confident answers over 1 km off, the
    median seconds, then the ``top`` most confident photos (confidence, error, fov)."""
    error = np.array([r.get("error_m", np.inf) for r in rows])
    confidence = confidences(np.array([margin_of(r, runner_up_m) for r in rows]),
                             np.array([log_best_of(r) for r in rows]), logit)
    threshold = fov_unknown_threshold(rows, logit, runner_up_m, floor)
    answered, right = confidence >= threshold, rows_right(rows)
    wrong_top = sorted(((float(c), r["photo"], round(float(e))) for c, r, e in zip(confidence, rows, error)
                        if e > 1000.0), reverse=True)[:3]
    lines = [f"{name}: {len(rows)} photos; best place within 100 m / 250 m / 1 km: "
             f"{int((error <= 100).sum())} / {int((error <= 250).sum())} / {int(right.sum())}; median error within "
             f"1 km {np.median(error[right]):.0f} m; threshold {threshold:.2f}: answered {int(answered.sum())}, right "
             f"{int((answered & right).sum())}; most confident > 1 km: "
             + ", ".join(f"{p} {e} m at {c:.3f}" for c, p, e in wrong_top)
             + f"; median seconds {np.median([r['seconds'] for r in rows]):.1f}"]
    for c, r, e in sorted(zip(confidence, rows, error), key=lambda t: -t[0])[:top]:
        lines.append(f"    {r['photo']:34s} {c:.4f} {e:9.0f} m  fov {r.get('fov', float('nan')):.2f}")
    return "\n".join(lines)


def fov_unknown_runs_report(runs: dict[str, list[str]]) -> str:
    """:func:`fov_unknown_report` of each run (a name and its ``bench-real`` JSON files, rows pooled) under the photo
    preset's fit, those whose files are all there."""
    from ..localizer.confidence import PHOTO_MARGIN_LOGIT, PHOTO_MIN_CONFIDENCE, PHOTO_RUNNER_UP_M

    reports = []
    for name, paths in runs.items():
        if all(os.path.exists(p) for p in paths):
            rows = []
            for path in paths:
                with open(path) as f:
                    rows += json.load(f)["photos"]
            reports.append(fov_unknown_report(name, rows, PHOTO_MARGIN_LOGIT, PHOTO_RUNNER_UP_M, PHOTO_MIN_CONFIDENCE))
    return "\n".join(reports)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=0, help="at most N photos, spread over the places")
    parser.add_argument("--out", default=PHOTO_CONFIDENCE_FILE)
    parser.add_argument("--rows", default=TRAINING_ROWS_FILE,
                        help="the localization rows (refined poses, truth) are written here, or read with --from-rows")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--from-rows", action="store_true", help="refit from the rows of an earlier run, localizing nothing")
    source.add_argument("--extend", action="store_true",
                        help="keep the rows already in --rows and localize only the photos they lack (same localizer code)")
    parser.add_argument("--model-set", default=None, metavar="JSON",
                        help="overrides of the photo preset's model parameters (a probe: write --rows and --out elsewhere)")
    parser.add_argument("--runner-up-choices", action="store_true",
                        help=f"choose the runner-up distance among {', '.join(f'{d:.0f}' for d in RUNNER_UP_CHOICES_M)} m "
                        f"on the training photos (default: {RUNNER_UP_M:.0f} m; see RUNNER_UP_CHOICES_M)")
    parser.add_argument("--score-term", action="store_true",
                        help="fit the log best score too (a probe, not the default: it did not hold on places left out)")
    parser.add_argument("--part-margin", action="store_true",
                        help="fit the answer's smallest part margin too (confidence.answer_part_margin; rendered for rows "
                        "without one, ~2 s a photo); an option, not the shipped fit (experiments/ch1/part-margin/)")
    parser.add_argument("--fov-unknown-rows", default=None, metavar="JSON", nargs="+",
                        help="`real_localize --side train --fov unknown --no-abstain` runs' JSON: the threshold with "
                        "the fov unknown is set on all their rows together (fov_unknown_threshold)")
    parser.add_argument("--second-opinion-rows", default=None, metavar="JSON", nargs="+",
                        help="`real_localize --side train|dev --fov unknown --no-abstain` runs' JSON on the photos of "
                        "--rows: the second opinion (LocalizeParams.second_opinion_from) is fitted on them "
                        "(fit_second_opinion)")
    args = parser.parse_args(argv)
    unknown_rows = second_rows = None
    for option, paths in (("--fov-unknown-rows", args.fov_unknown_rows), ("--second-opinion-rows", args.second_opinion_rows)):
        if not paths:
            continue
        read = []
        for path in paths:
            try:
                with open(path) as f:
                    modes = ("unknown",) if option == "--fov-unknown-rows" else ("unknown", "second")
                    read += [r for r in json.load(f)["photos"] if r["fov_mode"] in modes]
            except (OSError, ValueError, KeyError) as exc:
                print(f"{option}: cannot read {path}: {exc}")
                return 2
        if set(r["photo"] for r in read) & set(_validation_keys()):
            print(f"{option}: the rows hold validation photos; only training-side rows may be fitted on")
            return 2
        if option == "--fov-unknown-rows":
            unknown_rows = read
        else:
            second_rows = read
    if args.from_rows:
        try:
            with open(args.rows) as f:
                saved = json.load(f)
            rows, rows_commit = saved["rows"], saved.get("commit")
        except (OSError, ValueError, KeyError) as exc:
            print(f"--from-rows: cannot read the rows of {args.rows}: {exc}")
            return 2
    else:
        if not os.path.isdir(DEFAULT_PHOTOS):
            print(f"no photos at {DEFAULT_PHOTOS}")
            return 2
        items = [it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")]
        if args.limit:
            items = items[:: max(1, len(items) // args.limit)][: args.limit]
        done, rows_commit = {}, git_commit()
        if args.extend and os.path.exists(args.rows):
            with open(args.rows) as f:
                saved = json.load(f)
            done = {(r["photo"], r["fov_mode"]): r for r in saved["rows"]}
            rows_commit = f"{saved.get('commit')} ({len(done)} rows) + {rows_commit}"
        try:
            model_params = model_overrides(args.model_set)
        except ValueError as exc:
            print(f"--model-set: {exc}")
            return 2
        rows = run(items, ["known"], params=replace(LocalizeParams.for_photos(), min_confidence=0.0), done=done,
                   model_params=model_params)
        with open(args.rows, "w") as f:
            json.dump({"commit": rows_commit, "rows": rows}, f)
    choices = RUNNER_UP_CHOICES_M if args.runner_up_choices else (RUNNER_UP_M,)
    if args.part_margin:  # rows of runs before the part margin have none: rendered here (the places at RUNNER_UP_M)
        items = {it.key: it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")}
        with_part_margins(rows, items)
        if unknown_rows:
            with_part_margins(unknown_rows, items)
    out = {"commit": git_commit(), "localized_at": rows_commit,
           **fit_confidence(rows, choices, args.score_term, args.part_margin)}
    if unknown_rows:
        out["min_confidence_fov_unknown"] = fov_unknown_threshold(unknown_rows, out["logit"], out["runner_up_m"],
                                                                  out["min_confidence"])
        out["fov_unknown_rows"] = {"files": [os.path.relpath(p, REPO) for p in args.fov_unknown_rows],
                                   "photos": len(unknown_rows)}
    if second_rows:
        # what each photo's second opinion searches: a fov-unknown row, or a "second" row where the given fov lies
        # beyond the fov-unknown search's reach (real_localize.second_search_rows)
        focal = {it.key: it.focal_px for side in ("train", "dev") for it in items_on_side(side) if it.focal_px}
        searched = second_search_rows(second_rows, focal)
        missing = sorted(r["photo"] for r in rows if r["photo"] not in searched)
        if missing:
            print(f"--second-opinion-rows: no row of the second opinion's search for {' '.join(missing)} (their fov lies "
                  "beyond the fov-unknown search's reach: real_localize --fov second)")
            return 2
        out["second_opinion"] = fit_second_opinion(rows, list(searched.values()), out["logit"], out["runner_up_m"],
                                                   out["min_confidence"])
        out["second_opinion"]["files"] = [os.path.relpath(p, REPO) for p in args.second_opinion_rows]
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1)
    kept, loo = out["kept_by_runner_up_m"], out["leave_place_out"]
    print(f"{len(rows)} photos, {out['right']} within {RIGHT_M:.0f} m; logit {logit_text(out['logit'])}; "
          f"abstain below {out['min_confidence']:.2f}; runner-up beyond {out['runner_up_m']:.0f} m "
          f"(right answers kept: {', '.join(f'{d} m {k}' for d, k in kept.items())})"
          + (f"; fov unknown: abstain below {out['min_confidence_fov_unknown']:.2f} ({len(unknown_rows)} photos)"
             if unknown_rows else "") + "; leave place out (answered right / wrong): "
          + ", ".join(f"{name} {v['right']} / {v['wrong']}" for name, v in loo.items())
          + (f"; second opinion from {out['second_opinion']['from']:.2f}: gain {out['second_opinion']['gain']:.2f}, "
             f"answered right / wrong {out['second_opinion']['answered']['right']} / "
             f"{out['second_opinion']['answered']['wrong']}, leave place out "
             f"{out['second_opinion']['leave_place_out']['right']} / {out['second_opinion']['leave_place_out']['wrong']}"
             if second_rows else "") + f"; wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
