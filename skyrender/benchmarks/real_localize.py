"""Localization of real photographs (CH1) against a >= 1 degree SRTM mosaic around them.

``python -m skyrender.benchmarks.real_localize [--side validation] [--limit N]
[--fov known unknown] [--unknown-every K] [--out experiments/ch1]`` (``make bench-real``)

Per photo: the DEM is the mosaic of the SRTM3 tiles around its place, cropped to
1.2 deg of latitude x 1.4 deg of longitude centred on the place (the mean camera
position of the photos taken there, rounded to 0.1 deg), so the photos of one place
share one model (:meth:`ModelParams.for_photos`, built once and cached). The photo is
localized with :meth:`LocalizeParams.for_photos`, no prior, the camera 2 m above ground,
its skyline extracted by the learned extractor, the fov given (``known``: from its focal
length) or not (``unknown``). Reported per photo:
error of the position (m), status, confidence, seconds (extraction included, model
building not); and recall at 100 m / 250 m / 1 km (with its 95 % interval, the places resampled
whole: :func:`place_intervals`), abstentions and confident answers more than 1 km wrong, the
calibration of the confidence, how often the truth is among the places ``localize --candidates`` lists
(:func:`places_offered`) and a line per place.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np

from ..camera import horizontal_fov
from ..datasets.real_photos import DEFAULT_PHOTOS, REPO, items_on_side, photo_items, split_places
from ..diagnostics.oracle import DEM_DIR, tiles_around
from ..evaluate import cpu_description, git_commit, library_versions, machine_line, place_interval, position_errors

HALF_LAT, HALF_LON = 0.6, 0.7  # degrees either side of the place's centre
RECALL_M = (100.0, 250.0, 1000.0)


def place_window(lat: float, lon: float) -> tuple[float, float, float, float]:
    """(west, south, east, north) degrees of the search area around a place."""
    clat, clon = round(lat, 1), round(lon, 1)
    return clon - HALF_LON, clat - HALF_LAT, clon + HALF_LON, clat + HALF_LAT


def places_of(items) -> tuple[dict[str, str], dict[str, tuple[float, float]]]:
    """The place of each photo (:func:`split_places`) and the centre of each place of ``items`` (lat, lon: the
    mean position of all the data's photos taken there, whose window :func:`place_window` they share; the given
    photos' where the data has none of the place). All of them, not the given ones only: a photo's DEM window, and
    so its answer, must not depend on which other photos of its place a run holds (a run of one of place06's photos
    had a window 0.1 deg off the whole side's)."""
    place_of = split_places()
    wanted = {place_of[it.key] for it in items}
    pooled = [it for it in (photo_items() if wanted else []) if place_of.get(it.key) in wanted and it.lat is not None]
    covered = {place_of[it.key] for it in pooled}
    positions: dict[str, list] = {}
    for it in pooled + [it for it in items if place_of[it.key] not in covered]:
        positions.setdefault(place_of[it.key], []).append((it.lat, it.lon))
    return place_of, {place: tuple(np.mean(p, axis=0)) for place, p in positions.items()}


def place_dem(lat: float, lon: float):
    """(dem, window) of a place centred at (lat, lon): the SRTM3 mosaic within :func:`place_window`."""
    from ..dem import load_dem

    window = place_window(lat, lon)
    return load_dem(tiles_around(lat, lon, DEM_DIR), bounds=window), window


def load_place(lat: float, lon: float, model_params=None):
    """(dem, terrain, model, window) of a place centred at (lat, lon): :func:`place_dem`, its
    model (``model_params``, default the photo preset's) built once and cached."""
    from ..model import ModelParams, cached_model
    from ..render import Terrain

    dem, window = place_dem(lat, lon)
    terrain = Terrain(dem)
    return dem, terrain, cached_model(dem, model_params or ModelParams.for_photos(), terrain=terrain), window


def with_place(items, model_params=None):
    """(n, item, (dem, terrain, model)) for each of ``items`` in order: each place's
    :func:`load_place` (``model_params``: the model's, default the photo preset's) done when its
    first photo comes, one place in memory at a time (items come place by place)."""
    place_of, centres = places_of(items)
    loaded: dict = {}
    for n, it in enumerate(items):
        place = place_of[it.key]
        if place not in loaded:
            loaded.clear()
            loaded[place] = load_place(*centres[place], model_params)[:3]
        yield n, it, loaded[place]


def with_terrain(rows: list[dict], items: dict):
    """(row, item, terrain) for each of ``rows``, ``items`` mapping photo keys to their items (every photo of
    their places): each place's terrain (:func:`place_dem`) loaded when its first row comes, one place in
    memory at a time (rows come place by place)."""
    from ..render import Terrain

    place_of, centres = places_of(items.values())
    loaded: dict = {}
    for row in rows:
        it = items[row["photo"]]
        place = place_of[it.key]
        if place not in loaded:
            loaded.clear()
            loaded[place] = Terrain(place_dem(*centres[place])[0])
        yield row, it, loaded[place]


def model_overrides(text: str | None):
    """The photo preset's ModelParams with the JSON ``text``'s fields set (a probe), or None."""
    from ..model import ModelParams

    return ModelParams.from_dict(json.loads(text), ModelParams.for_photos()) if text else None


def true_extraction(item, height: int):
    """The photo's true skyline as an extraction: every column trusted, P(sky) 1 above it and 0 below."""
    from ..features.skyline import ExtractedSkyline, sky_mask_of_skyline

    sky = item.truth_skyline()
    return ExtractedSkyline(sky, np.ones(len(sky)), sky_mask_of_skyline(sky, height).astype(np.float32))


def run(items, fov_modes: list[str], progress: bool = True, params=None, unknown_every: int = 1,
        done: dict | None = None, on_row=None, model_params=None, true_skyline: bool = False) -> list[dict]:
    """Localize each photo (``params``: LocalizeParams, default the photo preset; ``model_params``:
    ModelParams, default the photo preset's; ``true_skyline``: from the photo's true skyline, every
    column trusted, instead of the extracted one: what a perfect extractor would give); rows as in
    the module doc; ``fov_modes`` of ``known``, ``unknown`` and ``second`` (the search of a fov-given answer's
    second opinion, :func:`~skyrender.localizer.pipeline.second_opinion_params`). The fov-unknown mode runs on
    every ``unknown_every``-th photo only (it searches several focal lengths, so it takes several times longer). ``done`` maps
    (photo, fov mode) to rows of an interrupted run, kept as they are (that place's model is
    not even loaded when all its photos are done); ``on_row(row)`` is called on each new row."""
    from ..features import extract_skyline, load_photo
    from ..localizer import LocalizeParams, localize
    from ..localizer.pipeline import second_opinion_params

    place_of, centres = places_of(items)
    loaded: dict[str, tuple] = {}
    params = params or LocalizeParams.for_photos()
    done = done or {}
    rows = []
    for n, it in enumerate(items):
        modes = [m for m in fov_modes if not (m == "unknown" and n % unknown_every)]
        if all((it.key, m) in done for m in modes):
            rows.extend(done[it.key, m] for m in modes)
            continue
        place = place_of[it.key]
        if place not in loaded:
            t = time.perf_counter()
            dem, terrain, model, window = load_place(*centres[place], model_params)
            loaded.clear()  # one place's model in memory at a time
            loaded[place] = (dem, terrain, model, time.perf_counter() - t, window)
        dem, terrain, model, model_seconds, window = loaded[place]
        tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
        for mode in modes:
            if (it.key, mode) in done:
                rows.append(done[it.key, mode])
                continue
            t = time.perf_counter()
            image = load_photo(it.image_path)
            skyline = true_extraction(it, image.shape[0]) if true_skyline else extract_skyline(image, params.skyline_params())
            given = horizontal_fov(image.shape[1], it.focal_px)
            # "second": the search a fov-given answer's second opinion runs (the fov unknown, its range scaled to the
            # given fov where the fov-unknown search does not reach it), for fitting the second opinion
            run_params = second_opinion_params(params, given) if mode == "second" else params
            result = localize(image, model, 2.0, given if mode == "known" else None, terrain=terrain, skyline=skyline,
                              params=run_params)
            seconds = time.perf_counter() - t
            row = {"photo": it.key, "fov_mode": mode, "status": result.status, "confidence": result.confidence,
                   "seconds": seconds, "model_seconds": model_seconds, "window": window, "width": image.shape[1],
                   "stage_seconds": result.stats.to_dict()["seconds"], "best_score": result.stats.best_score,
                   "runner_up_score": result.stats.runner_up_score, "part_margin": result.stats.part_margin,
                   "truth_xy": [tx, ty],
                   "refined_poses": [list(r) for r in result.stats.refined_poses],
                   "refined_slopes": list(result.stats.refined_slopes),
                   "second_opinion": result.stats.second_opinion}
            if math.isfinite(params.max_answer_slope_deg):  # the answer was chosen among poses on such ground
                row["max_answer_slope_deg"] = params.max_answer_slope_deg
            if result.localized:
                row["error_m"] = float(position_errors(result.pose, np.array([tx, ty]))[0])
                row["fov"] = result.fov
                row["pose"] = [float(v) for v in result.pose]
                row["height_m"] = float(result.pose[2] - dem.ground(result.pose[0], result.pose[1]))
            rows.append(row)
            if on_row is not None:
                on_row(row)
            if progress:
                err = f"{row['error_m']:.0f} m" if "error_m" in row else "-"
                print(f"  [{n + 1}/{len(items)}] {it.key} ({mode} fov): {row['status']}, error {err}, "
                      f"confidence {row['confidence']:.2f}, {seconds:.1f} s", flush=True)
    return rows


def summary(rows: list[dict]) -> dict:
    n = len(rows)
    err = np.array([r.get("error_m", np.inf) for r in rows])
    out = {"photos": n, "abstained": int(sum(r["status"] != "localized" for r in rows)),
           "wrong_over_1km": int(np.sum(np.isfinite(err) & (err > 1000))),
           # abstentions whose withheld answer (a --no-abstain run, rescored) was within 1 km
           "withheld_within_1km": int(sum(r.get("withheld_error_m", np.inf) <= 1000 for r in rows)),
           "median_seconds": float(np.median([r["seconds"] for r in rows])) if n else None}
    for m in RECALL_M:
        out[f"recall_{int(m)}m"] = float(np.mean(err <= m)) if n else 0.0
    return out


#: Confidence bins of :func:`calibration` (lower edges; the last bin holds 1.0).
CALIBRATION_BINS = (0.0, 0.5, 0.8, 0.95, 0.99)


def calibration(rows: list[dict], right_m: float = 1000.0) -> dict:
    """Whether a confidence means the probability of being within ``right_m`` (m): every row's answer, given or
    withheld (its best refined pose, :func:`answer_xy`, against its true position), binned by its confidence
    (:data:`CALIBRATION_BINS`): photos, mean confidence and share within ``right_m`` per bin, and the Brier score (the
    mean squared difference of confidence and outcome). Rows without refined poses or truth are left out."""
    conf, right = [], []
    for r in rows:
        xy = answer_xy(r)
        if r.get("truth_xy") is None or not np.isfinite(xy).all():
            continue
        conf.append(float(r["confidence"]))
        right.append(float(np.hypot(*(xy - np.asarray(r["truth_xy"], np.float64))) <= right_m))
    conf_a, right_a = np.array(conf), np.array(right)
    edges = np.r_[CALIBRATION_BINS, np.inf]
    bins = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        pick = (conf_a >= lo) & (conf_a < hi) if np.isfinite(hi) else conf_a >= lo
        bins.append({"from": float(lo), "photos": int(pick.sum()),
                     "mean_confidence": float(conf_a[pick].mean()) if pick.any() else None,
                     "share_right": float(right_a[pick].mean()) if pick.any() else None})
    return {"right_m": right_m, "photos": len(conf), "bins": bins,
            "brier": float(np.mean((conf_a - right_a) ** 2)) if len(conf) else None}


def by_place(rows: list[dict], place_of: dict[str, str]) -> dict[str, dict]:
    """Per place (``place_of``: photo key -> place; "?" for a photo it lacks), in place order: the
    photos, and how many ended within 250 m and within 1 km, answered or withheld (a rescored
    abstention's answer counts). A change is judged place by place: one place holds 52 of the 73
    training-side photos, and a focal-length fit that helped there only was worse on validation
    (``experiments/ch1/refine-fov-known/``)."""
    out: dict[str, dict] = {}
    for r in rows:
        err = r.get("error_m", r.get("withheld_error_m", np.inf))
        p = out.setdefault(place_of.get(r["photo"], "?"), {"photos": 0, "within_250m": 0, "within_1000m": 0})
        p["photos"] += 1
        p["within_250m"] += int(err <= 250.0)
        p["within_1000m"] += int(err <= 1000.0)
    return dict(sorted(out.items()))


def place_intervals(rows: list[dict], place_of: dict[str, str], level: float = 0.95) -> dict:
    """How far the recall of ``rows`` (one fov mode) could move with other places of the same kind: for each radius
    of :data:`RECALL_M`, the :func:`~skyrender.evaluate.place_interval` of the share answered within it, the places
    (``place_of``; a photo it lacks is a place of its own) resampled whole."""
    hit = np.array([r.get("error_m", np.inf) for r in rows], np.float64)
    labels = [place_of.get(r["photo"], r["photo"]) for r in rows]
    out = {"level": level, "places": len(set(labels))}
    for m in RECALL_M:
        out[f"recall_{int(m)}m"] = list(place_interval(hit <= m, labels, level=level)) if rows else None
    return out


#: :func:`places_offered`: how many of the distinct places ``localize --candidates`` lists are counted.
PLACES_OFFERED = (1, 3)


def places_offered(rows: list[dict], ks: tuple[int, ...] = PLACES_OFFERED, right_m: float = 1000.0,
                   apart_m: float = 1000.0) -> dict:
    """What an analyst finds among the places ``skyrender localize --candidates K`` lists
    (:meth:`~skyrender.localizer.LocalizationResult.places`: the distinct places refined, ``apart_m`` apart, the
    answer's first, given or withheld): for each K of ``ks``, how many photos have their true position within
    ``right_m`` of one of the first K. Rows without refined poses count as misses."""
    from ..localizer.confidence import distinct_places

    hits = dict.fromkeys(ks, 0)
    for r in rows:
        poses = refined_of(r)
        if not len(poses) or r.get("truth_xy") is None:
            continue
        dist = np.hypot(*(poses[distinct_places(poses, max(ks), apart_m), :2] - np.asarray(r["truth_xy"])).T)
        for k in ks:
            hits[k] += bool((dist[:k] <= right_m).any())
    return {"photos": len(rows), "right_m": right_m, "within": {str(k): n for k, n in hits.items()}}


def refined_of(row: dict, max_slope_deg: float | None = None) -> np.ndarray:
    """The row's refined poses (K, 8: x, y, z, pan, tilt, swing, f_px, score) the answer is chosen
    among: those whose ground slopes at most ``max_slope_deg`` (default the row's own
    ``max_answer_slope_deg``, ``LocalizeParams.max_answer_slope_deg`` of its run; none: every pose),
    by the row's ``refined_slopes`` (:func:`~skyrender.localizer.pipeline.standable_mask`, as the
    localizer chooses); every pose where the row keeps no slopes."""
    from ..localizer.pipeline import standable_mask

    poses = np.asarray(row.get("refined_poses") or [], np.float64).reshape(-1, 8)
    slopes = row.get("refined_slopes") or []
    bound = row.get("max_answer_slope_deg", np.inf) if max_slope_deg is None else max_slope_deg
    return poses[standable_mask(slopes, bound)] if len(slopes) == len(poses) and len(poses) else poses


def photo_skyline(item, params=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(image, skyline (W,) float64, column weights (W,)) of a photo as the photo preset (``params``, default
    :meth:`LocalizeParams.for_photos`) localizes it: loaded, its skyline extracted by the preset's extractor,
    the columns weighted by their confidence (:func:`~skyrender.localizer.pipeline.column_weights`)."""
    from ..features import extract_skyline, load_photo
    from ..localizer import LocalizeParams
    from ..localizer.pipeline import column_weights

    params = params or LocalizeParams.for_photos()
    image = load_photo(item.image_path)
    ext = extract_skyline(image, params.skyline_params())
    return image, ext.skyline.astype(np.float64), column_weights(ext.confidence, params.confidence_power)


def photo_scaled_up(item, factor: int) -> tuple[np.ndarray, np.ndarray, float]:
    """(the photo, the photo ``factor`` times as wide and high (bicubic), its horizontal fov in degrees): a CH1
    photo as a stand-in for a phone photo of that size (4: about 11-12.6 MP), the fov the same at either size."""
    import cv2

    from ..features import load_photo

    image = load_photo(item.image_path)
    big = cv2.resize(image, (image.shape[1] * factor, image.shape[0] * factor), interpolation=cv2.INTER_CUBIC)
    return image, big, horizontal_fov(image.shape[1], item.focal_px)


def stored_places(rows: list[dict] | None = None, items: dict | None = None, places: int = 4,
                  with_distance: bool = False, params=None):
    """The frame of the probes that score stored answers again: for each row (rows come place by place;
    ``items`` as for :func:`with_terrain`; None: the shipped confidence's 73 training-side rows,
    ``localize_fit.TRAINING_ROWS_FILE``, and the training side's CH1 photos), its best ``places`` distinct
    places (more than 1 km apart, :func:`~skyrender.localizer.confidence.distinct_places`) among its refined
    poses, rendered with their own focal lengths (rows without refined poses are passed over). Yields (row,
    item, skyline (W,), column weights (W,) — the photo as the photo preset (``params``) sees it,
    :func:`photo_skyline` — the places' poses (P, 8), their rendered skylines (P, W), and with
    ``with_distance`` each column's terrain distance (P, W, m), else None)."""
    from ..camera import Intrinsics
    from ..localizer.confidence import distinct_places
    from ..render.skyline import render_skylines

    if rows is None:
        from ..training.localize_fit import TRAINING_ROWS_FILE

        with open(TRAINING_ROWS_FILE) as f:
            rows = json.load(f)["rows"]
    if items is None:
        items = {it.key: it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")}
    for row, it, terrain in with_terrain(rows, items):
        image, sky, weights = photo_skyline(it, params)
        H, W = image.shape[:2]
        poses = refined_of(row)
        picked = poses[distinct_places(poses, places)]
        if not len(picked):
            continue
        k = np.column_stack([picked[:, 6], np.full(len(picked), W / 2.0), np.full(len(picked), H / 2.0)])
        out = render_skylines(terrain, picked[:, :6], Intrinsics(W, H, float(picked[0, 6]), W / 2.0, H / 2.0),
                              per_pose_intrinsics=k, with_distance=with_distance)
        rendered, distance = out if with_distance else (out, None)
        yield row, it, sky, weights, picked, rendered, distance


def place_report(records: list[dict], names: list[str], out_path: str, right_m: float = 1000.0) -> None:
    """Write probe records (``{"dist_m": [each place's distance to the truth, ...], "scores": {name: [each
    place's score, ...]}}``, from :func:`stored_places`) to ``out_path`` (JSON) and print, for each score
    ``name``, how many photos' best-scoring place lies within ``right_m`` and the median margin 1 - best / next
    place's score of those photos and of the others (nan where none)."""
    with open(out_path, "w") as f:
        json.dump(records, f, indent=1)
    width = max(len(n) for n in names)
    for name in names:
        right, margins = 0, {True: [], False: []}
        for rec in records:
            s, d = np.asarray(rec["scores"][name], np.float64), np.asarray(rec["dist_m"], np.float64)
            b = int(np.argmin(s))
            ok = bool(d[b] <= right_m)
            right += ok
            rest = np.delete(s, b)
            if len(rest) and np.isfinite(rest.min()) and rest.min() > 0:
                margins[ok].append(1.0 - s[b] / rest.min())
        med = {k: float(np.median(v)) if v else float("nan") for k, v in margins.items()}
        print(f"{name:{width}s}: best place within {right_m:.0f} m on {right} of {len(records)}; margin median "
              f"right {med[True]:.3f}, wrong {med[False]:.3f}")


def with_part_margins(rows: list[dict], items: dict, params=None) -> list[dict]:
    """``rows``, each given a ``part_margin`` where it has refined poses but no part margin: the
    photo-confidence cue :func:`~skyrender.localizer.confidence.answer_part_margin` of its refined poses
    against the photo's skyline as the photo preset (``params``) extracts it (:func:`photo_skyline`); rows of
    runs at this code carry theirs. ``items`` maps photo keys to items (every photo of their places; :func:`with_terrain`)."""
    from ..localizer import LocalizeParams
    from ..localizer.confidence import answer_part_margin

    params = params or LocalizeParams.for_photos()
    missing = [r for r in rows if r.get("part_margin") is None and len(refined_of(r))]
    for row, it, terrain in with_terrain(missing, items):
        image, sky, weights = photo_skyline(it, params)
        row["part_margin"] = answer_part_margin(terrain, refined_of(row), sky, weights, image.shape[0],
                                                params.places_apart_m, params.score)
    return rows


def margin_of(row: dict, runner_up_m: float = 1000.0) -> float:
    """1 - best / runner-up refined score, the runner-up the best refined pose farther than
    ``runner_up_m`` (m) from the answer (among the row's :func:`refined_of`; a row without them
    keeps the run's own runner-up score); 1 without a runner-up, NaN without a pose."""
    from ..localizer.confidence import runner_up_index

    poses = refined_of(row)
    if len(poses):
        best = int(np.argmin(poses[:, 7]))
        i = runner_up_index(poses[:, :2], poses[:, 7], best, runner_up_m)
        return 1.0 - poses[best, 7] / poses[i, 7] if i is not None else 1.0
    best, runner = row.get("best_score"), row.get("runner_up_score")
    if best is None:
        return float("nan")
    return 1.0 - best / runner if runner else 1.0


def answer_xy(row: dict) -> np.ndarray:
    """(2,) the position (m) of the row's answer, withheld or not: its best refined pose (:func:`refined_of`);
    NaN without one."""
    poses = refined_of(row)
    return poses[int(np.argmin(poses[:, 7])), :2] if len(poses) else np.full(2, np.nan)


def apart_m(row: dict, other: dict) -> float:
    """How far apart (m) two rows' answers are (:func:`answer_xy`): a photo's fov-given answer and the one a search
    with the fov unknown gives it (the second opinion, ``LocalizeParams.second_opinion_from``); NaN without both."""
    return float(np.hypot(*(answer_xy(row) - answer_xy(other))))


def log_best_of(row: dict) -> float:
    """ln of the row's best refined score, rescaled to the reference width (:func:`confidence.log_score`;
    the row's ``width``, else 1024 px: every CH1 photo); the best as :func:`margin_of` takes it; NaN
    without a pose."""
    from ..localizer.confidence import SCORE_REFERENCE_WIDTH_PX, log_score

    poses = refined_of(row)
    best = poses[:, 7].min() if len(poses) else row.get("best_score")
    if best is None:
        return float("nan")
    return float(log_score(best, row.get("width", SCORE_REFERENCE_WIDTH_PX)))


def logit_text(logit) -> str:
    """A photo-confidence logit as a formula: a + b m (+ c ln s) (+ d h, h the smallest part margin)."""
    text = f"{logit[0]:.3f} + {logit[1]:.3f} m"
    if len(logit) > 2 and logit[2] != 0.0:
        text += f" {logit[2]:+.3f} ln s"
    if len(logit) > 3 and logit[3] != 0.0:
        text += f" {logit[3]:+.3f} h"
    return text


def second_search_rows(rows: list[dict], focal_px: dict[str, float], params=None) -> dict[str, dict]:
    """{photo: the row that gives what a fov-given answer's second opinion searches}: the photo's ``second`` row
    (``--fov second``), else its fov-unknown row where that search is the second opinion's to the bit: the photo's
    given fov (:func:`~skyrender.camera.horizontal_fov` of ``focal_px``, px, at the row's ``width``, CH1's 1024 px
    where it has none) within the fov-unknown search's reach (``params``, the photo preset:
    :func:`~skyrender.localizer.pipeline.fov_within_reach`). A photo with neither has none."""
    from ..localizer import LocalizeParams
    from ..localizer.confidence import SCORE_REFERENCE_WIDTH_PX
    from ..localizer.pipeline import fov_within_reach

    params = params or LocalizeParams.for_photos()
    out = {r["photo"]: r for r in rows if r.get("fov_mode") == "unknown" and r["photo"] in focal_px
           and fov_within_reach(params, horizontal_fov(r.get("width", SCORE_REFERENCE_WIDTH_PX), focal_px[r["photo"]]))}
    out.update({r["photo"]: r for r in rows if r.get("fov_mode") == "second"})
    return out


def rescore(rows: list[dict], logit: tuple, threshold: float, runner_up_m: float = 1000.0,
            threshold_fov_unknown: float | None = None, second_opinion: dict | None = None,
            focal_px: dict[str, float] | None = None) -> list[dict]:
    """The rows under another photo confidence (logistic ``logit`` of the margin to the best
    refined pose farther than ``runner_up_m``, :func:`margin_of`, and of the best score,
    :func:`log_best_of`; abstaining below ``threshold``, or
    ``threshold_fov_unknown`` on the rows localized with the fov unknown when given):
    the poses do not depend on it, so an answer stays or becomes an abstention (its error kept as
    ``withheld_error_m``), and an answer an earlier rescore withheld is given again. An abstention of
    the run itself that the new confidence would answer needs a new run (its pose was not kept):
    ValueError. A ``logit`` with a part-margin term reads each row's ``part_margin``
    (:func:`with_part_margins`); a row with poses but none: ValueError. With ``second_opinion`` (a fit's: ``from``,
    ``gain``, ``apart_m``) a fov-given row withheld with at least ``from`` gains ``gain`` where the second search's best
    place lies within ``apart_m`` (:func:`~skyrender.localizer.confidence.agreed_confidence`): the row's own second opinion,
    or, where it asked none (a run without abstention), the row of ``rows`` that gives what the second search would
    (:func:`second_search_rows`; ``focal_px``: the photos' focal lengths, px); with neither, ValueError."""
    from ..localizer.confidence import agreed_confidence, margin_logistic, uses_part_margin

    second_rows = second_search_rows(rows, focal_px or {})
    out = []
    for r in rows:
        r = dict(r)
        margin = margin_of(r, runner_up_m)
        if np.isfinite(margin):
            part = r.get("part_margin")
            if part is None and uses_part_margin(logit):
                raise ValueError(f"{r['photo']}: no part margin (real_localize.with_part_margins)")
            r["confidence"] = float(margin_logistic(margin, logit, log_best_of(r), part or 0.0))
            if (second_opinion and r.get("fov_mode") == "known"
                    and second_opinion["from"] <= r["confidence"] < threshold):
                if r.get("second_opinion"):
                    apart = float(r["second_opinion"]["apart_m"])
                elif r["photo"] in second_rows:
                    apart = apart_m(r, second_rows[r["photo"]])
                else:
                    raise ValueError(f"{r['photo']}: asks for a second opinion that the run has not got "
                                     "(run it with --fov known unknown, or --fov known second)")
                if apart <= second_opinion["apart_m"]:
                    r["confidence"] = agreed_confidence(r["confidence"], second_opinion["gain"])
        fov_free = r.get("fov_mode") in ("unknown", "second")  # a "second" row is a search with the fov unknown too
        needed = threshold_fov_unknown if fov_free and threshold_fov_unknown is not None else threshold
        if r["status"] == "localized" and r["confidence"] < needed:
            r["status"], r["withheld_error_m"] = "abstained", r.pop("error_m")
        elif r["status"] != "localized" and r["confidence"] >= needed and "withheld_error_m" in r:
            r["status"], r["error_m"] = "localized", r.pop("withheld_error_m")  # withheld by an earlier rescore
        elif r["status"] != "localized" and r["confidence"] >= needed:
            raise ValueError(f"{r['photo']}: abstained in the run but answers now; run the benchmark again")
        out.append(r)
    return out


def table(report: dict) -> str:
    """The per-photo table and the summaries. An abstention's confidence is the one it
    fell short with; a withheld answer's error (``--rescore``) is shown in brackets."""
    lines = [f"{'photo':36s} {'fov':8s} {'status':10s} {'error m':>9s} {'conf':>5s} {'s':>6s}"]
    for r in report["photos"]:
        err = (f"{r['error_m']:9.0f}" if "error_m" in r else
               f"{'(%.0f)' % r['withheld_error_m']:>9s}" if "withheld_error_m" in r else f"{'-':>9s}")
        lines.append(f"{r['photo']:36s} {r['fov_mode']:8s} {r['status']:10s} {err} {r['confidence']:5.2f} {r['seconds']:6.1f}")
    for m, s in report["summary"].items():
        lines.append(f"{m} fov: {s['photos']} photos; within 100 m {100 * s['recall_100m']:.0f} %, 250 m "
                     f"{100 * s['recall_250m']:.0f} %, 1 km {100 * s['recall_1000m']:.0f} %; abstained {s['abstained']}; "
                     f"confident and > 1 km wrong {s['wrong_over_1km']}; median {s['median_seconds']:.1f} s"
                     + (f"; withheld but within 1 km {s['withheld_within_1km']}" if s.get("withheld_within_1km") else ""))
    for m, ci in report.get("intervals", {}).items():
        if ci.get("recall_1000m"):
            lines.append(f"{m} fov, {100 * ci['level']:.0f} % interval with the {ci['places']} places resampled whole: "
                         + ", ".join(f"within {label} {100 * ci[key][0]:.0f}-{100 * ci[key][1]:.0f} %" for label, key in
                                     (("100 m", "recall_100m"), ("250 m", "recall_250m"), ("1 km", "recall_1000m"))))
    for m, cal in report.get("calibration", {}).items():
        if cal["photos"]:
            lines.append(f"{m} fov calibration (every answer, given or withheld; confidence from: photos, mean confidence, "
                         f"share within {cal['right_m'] / 1000:.0f} km): " + ", ".join(
                             f"{b['from']:.2f}: {b['photos']}" + (f", {b['mean_confidence']:.2f}, {b['share_right']:.2f}"
                                                                  if b["photos"] else "") for b in cal["bins"])
                         + f"; Brier {cal['brier']:.3f}")
    for m, offered in report.get("places_offered", {}).items():
        first, *more = offered["within"].items()
        lines.append(f"{m} fov, the places listed (localize --candidates; the answer's first, given or withheld): the "
                     f"truth within {offered['right_m'] / 1000:.0f} km of the first on {first[1]} of {offered['photos']}"
                     + "".join(f", of one of the first {k} on {n}" for k, n in more))
    for m, places in report.get("by_place", {}).items():
        lines.append(f"{m} fov by place (within 250 m / 1 km of photos, answered or withheld): " + ", ".join(
            f"{name.split('/')[-1]} {p['within_250m']} / {p['within_1000m']} of {p['photos']}" for name, p in places.items()))
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", default="validation", choices=["train", "dev", "validation"])
    parser.add_argument("--limit", type=int, default=0, help="at most N photos, spread over the side's places")
    parser.add_argument("--fov", nargs="+", default=["known", "unknown"], choices=["known", "unknown", "second"],
                        help="fov modes: given, unknown, and 'second': the search a fov-given answer's second opinion "
                        "runs (the fov unknown, its range scaled to the given fov beyond the fov-unknown search's reach)")
    parser.add_argument("--unknown-every", type=int, default=1, help="the fov-unknown mode on every K-th photo only")
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "ch1"))
    parser.add_argument("--photos", nargs="+", default=None, help="these photos of the side only (keys, e.g. ch1/IMG_4922_01024)")
    parser.add_argument("--set", default=None, metavar="JSON",
                        help='overrides of the photo preset, e.g. \'{"refine": {"fit_height_m": 50}}\' (a probe)')
    parser.add_argument("--model-set", default=None, metavar="JSON",
                        help="overrides of the photo preset's model parameters (a probe; its own cached models)")
    parser.add_argument("--true-skyline", action="store_true",
                        help="a diagnostic: localize from each photo's true skyline (its mask), not the extracted one")
    parser.add_argument("--no-abstain", action="store_true", help="min_confidence 0: every photo answered")
    parser.add_argument("--tag", default="", help="output files bench-real-<side>-<tag>.*")
    parser.add_argument("--retable", action="store_true", help="rewrite the text table from the run's JSON")
    parser.add_argument("--rescore", action="store_true", help="with --retable: apply the current photo confidence "
                        "fit and threshold to the run's rows (their poses do not depend on it)")
    parser.add_argument("--fit", default=None, metavar="JSON",
                        help="with --rescore: another photo-confidence fit (a localize_fit output) instead of the shipped one")
    args = parser.parse_args(argv)
    if not os.path.isdir(DEFAULT_PHOTOS):
        print(f"no photos at {DEFAULT_PHOTOS}")
        return 2
    items = [it for it in items_on_side(args.side) if it.key.startswith("ch1/")]
    from ..localizer import LocalizeParams

    params = LocalizeParams.for_photos()
    if args.true_skyline:  # a skyline given, not extracted: the confidence fitted for such skylines
        params = params.for_given_skyline()
    if args.set:
        try:
            params = LocalizeParams.from_dict(json.loads(args.set), params)
        except ValueError as exc:
            print(f"--set: {exc}")
            return 2
    try:
        model_params = model_overrides(args.model_set)
    except ValueError as exc:
        print(f"--model-set: {exc}")
        return 2
    if args.photos:
        unknown = sorted(set(args.photos) - {it.key for it in items})
        if unknown:  # a mistyped key would otherwise run nothing and say nothing
            print(f"--photos: not CH1 photos of the {args.side} side: {' '.join(unknown)} (keys look like "
                  "ch1/IMG_4922_01024)")
            return 2
        items = [it for it in items if it.key in set(args.photos)]
    if args.limit:
        items = items[:: max(1, len(items) // args.limit)][: args.limit]
    if args.no_abstain:
        params = LocalizeParams.from_dict({"min_confidence": 0.0, "min_confidence_fov_unknown": 0.0}, params)
    name = f"bench-real-{args.side}{'-' + args.tag if args.tag else ''}"
    if args.retable:  # rewrite the text table of a finished run from its JSON
        try:
            with open(os.path.join(args.out, f"{name}.json")) as f:
                report = json.load(f)
        except (OSError, ValueError) as exc:
            print(f"--retable: no finished run {name}.json in {args.out}: {exc}")
            return 2
        if args.rescore:
            from ..localizer.confidence import GIVEN_SKYLINE_CONFIDENCE_FILE, PHOTO_CONFIDENCE_FILE, uses_part_margin

            # a run from the masks' skylines is rescored with the confidence fitted for given skylines
            shipped = (GIVEN_SKYLINE_CONFIDENCE_FILE if (report.get("overrides") or {}).get("true_skyline")
                       else PHOTO_CONFIDENCE_FILE)
            try:
                with open(args.fit or shipped) as f:
                    fit = json.load(f)
                logit, threshold = tuple(float(v) for v in fit["logit"]), float(fit["min_confidence"])
                runner_up_m = float(fit.get("runner_up_m", 1000.0))
                threshold_unknown = float(fit.get("min_confidence_fov_unknown", threshold))
                second = fit.get("second_opinion")
                second = second and {k: float(second[k]) for k in ("from", "gain", "apart_m")}
            except (OSError, ValueError, KeyError, TypeError) as exc:
                print(f"--fit: cannot read a photo-confidence fit from {args.fit or shipped}: {exc}")
                return 2
            if any("refined_poses" not in r for r in report["photos"]) and runner_up_m != 1000.0:
                print(f"--rescore: {name} keeps no refined poses, so its runner-ups beyond {runner_up_m:.0f} m "
                      "are unknown; run the benchmark again")
                return 2
            if uses_part_margin(logit):  # rows of runs before the part margin: rendered now
                with_part_margins(report["photos"], {it.key: it for it in items_on_side(args.side) if it.lat is not None})
            try:
                focal = {it.key: it.focal_px for it in photo_items() if it.focal_px}
                report["photos"] = rescore(report["photos"], logit, threshold, runner_up_m, threshold_unknown, second,
                                           focal)
            except ValueError as exc:
                print(f"--rescore: {exc}")
                return 2
            report["rescored"] = {"at": git_commit(), "logit": list(logit), "min_confidence": threshold,
                                  "runner_up_m": runner_up_m, "min_confidence_fov_unknown": threshold_unknown,
                                  "second_opinion": second,
                                  **({"fit": os.path.relpath(args.fit, REPO)} if args.fit else {})}
    else:
        # rows are appended to <name>.rows.jsonl as they come, so an interrupted run resumes
        os.makedirs(args.out, exist_ok=True)
        rows_path = os.path.join(args.out, f"{name}.rows.jsonl")
        done = {}
        if os.path.exists(rows_path):
            with open(rows_path) as f:
                for line in f:
                    if line.strip():
                        r = json.loads(line)
                        done[r["photo"], r["fov_mode"]] = r
            print(f"resuming: {len(done)} rows of {rows_path} kept")

        def append_row(row: dict) -> None:
            with open(rows_path, "a") as f:
                f.write(json.dumps(row) + "\n")

        commit = git_commit()  # the code that runs, not what the tree holds when the run ends
        rows = run(items, args.fov, params=params, unknown_every=max(1, args.unknown_every), done=done, on_row=append_row,
                   model_params=model_params, true_skyline=args.true_skyline)
        report = {"commit": commit, "cpus": os.cpu_count(), "cpu_model": cpu_description(), "versions": library_versions(),
                  "side": args.side, "photos": rows}
        if args.set or args.no_abstain or args.model_set or args.true_skyline:
            report["overrides"] = {"set": json.loads(args.set) if args.set else None, "no_abstain": args.no_abstain,
                                   "model_set": json.loads(args.model_set) if args.model_set else None,
                                   "true_skyline": args.true_skyline}
    modes = [m for m in args.fov if any(r["fov_mode"] == m for r in report["photos"])]  # a run of one mode: that one
    report["summary"] = {m: summary([r for r in report["photos"] if r["fov_mode"] == m]) for m in modes}
    place_of = split_places()
    report["by_place"] = {m: by_place([r for r in report["photos"] if r["fov_mode"] == m], place_of) for m in modes}
    report["calibration"] = {m: calibration([r for r in report["photos"] if r["fov_mode"] == m]) for m in modes}
    report["intervals"] = {m: place_intervals([r for r in report["photos"] if r["fov_mode"] == m], place_of)
                           for m in modes}
    report["places_offered"] = {m: places_offered([r for r in report["photos"] if r["fov_mode"] == m]) for m in modes}
    text = table(report)
    print(text)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, f"{name}.json"), "w") as f:
        json.dump(report, f, indent=1)
    with open(os.path.join(args.out, f"{name}.txt"), "w") as f:
        head = f"commit {report['commit']}, {machine_line(report)}, side {args.side}"
        if "overrides" in report:
            head += f"; photo preset with {json.dumps(report['overrides'])}"
        if "merged" in report:  # modes from two runs (one mode's code unchanged between them)
            head += "; rows merged: " + "; ".join(f"{mode}: {where}" for mode, where in report["merged"].items())
        if "rescored" in report:
            rs = report["rescored"]
            head += (f"; confidences rescored at {rs['at']} (logit {logit_text(rs['logit'])}, "
                     f"runner-up beyond {rs.get('runner_up_m', 1000.0):.0f} m, abstain below {rs['min_confidence']:.2f}"
                     + (f", with the fov unknown below {rs['min_confidence_fov_unknown']:.2f}"
                        if rs.get("min_confidence_fov_unknown", rs["min_confidence"]) != rs["min_confidence"] else "") + ")")
        f.write(f"{head}\n\n{text}\n")
    if not args.retable and os.path.exists(rows_path):
        os.remove(rows_path)  # the run is whole in <name>.json; a new run with this tag starts afresh
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
