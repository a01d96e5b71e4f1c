"""Skyline extraction on real photographs against their truth, per side of the fixed split.

``python -m skyrender.benchmarks.skyline_photos [--data DIR] [--sides validation heldout]
[--methods select hybrid net gmm otsu] [--out experiments/photos]``

For every photo: median absolute column error (px), the share of columns within 5 px
and seconds, for the photo extractor (``select``: ``hybrid`` and ``gmm``, the one more
confident where they part), ``hybrid`` (the network's boundary seeds per-photo colour
mixtures; the photo extractor until 2026-12-04), the learned extractor alone (``net``), the per-photo colour-mixture
extractor (``gmm``, its parameters set by hand on the ten ``heldout`` photos) and an
Otsu-threshold baseline, all in the same run; the confidence split is the first method's, the speed
the first extractor's (not Otsu's). Sides (``experiments/photos/split.json``):
``validation`` (CH1 photos of places never trained on, web045-web064), ``heldout`` (the
Web and GeoPose3K photos, never trained on) and ``train`` (what the network was fitted on;
not an unseen-photo figure). Also: the share of columns whose truth has no visible colour
edge near it (truth no photo-based method can follow), and the error of high- against
low-confidence columns, and each summary's 95 % interval with the places resampled whole. Writes
``bench-skyline.json`` (with the commit) and the table; ``--retable`` writes the table again from that JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from ..datasets.real_photos import DEFAULT_PHOTOS, REPO, items_on_side, split_places
from ..evaluate import cpu_description, git_commit, library_versions, machine_line, place_interval

TARGET_MEDIAN_PX, TARGET_WITHIN5 = 2.0, 0.95
GOAL_SHARE, GOAL_MEAN, GOAL_FLOOR = 0.90, 0.97, 0.60  # issue 18: on photos not used for fitting
CONFIDENT = 0.5  # columns at or above this confidence count as confident


def column_errors(skyline: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """|error| per column with truth; a column we left NaN (or vice versa) counts as H px wrong."""
    has = np.isfinite(truth)
    e = np.abs(skyline[has] - truth[has])
    return np.where(np.isfinite(e), e, 1e6)


def truth_without_edge(image: np.ndarray, truth: np.ndarray, *, reach: int = 3, rows: int = 4,
                       min_contrast: float = 8.0) -> np.ndarray:
    """(W,) bool: columns whose true boundary has no visible colour edge near it.

    The contrast of a boundary at row b is the Lab distance between the mean of the
    ``rows`` pixels above and below it; a column is flagged when no boundary within
    ``reach`` px of the truth reaches ``min_contrast``. Flags truth that no image method
    can see (a ridge hidden inside a cloud); False where the truth is NaN.
    """
    from ..features.sky import pixel_features

    lab = pixel_features(image)[..., :3].astype(np.float64)
    H, W = lab.shape[:2]
    csum = np.concatenate([np.zeros((1, W, 3)), np.cumsum(lab, axis=0)])  # csum[k] = sum of rows < k
    b = np.arange(rows, H - rows + 1)
    contrast = np.zeros((H + 1, W))
    contrast[b] = np.linalg.norm((csum[b] - csum[b - rows]) - (csum[b + rows] - csum[b]), axis=2) / rows
    has = np.isfinite(truth)
    t = np.round(np.where(has, truth, 0)).astype(int)
    near = np.clip(t[None, :] + np.arange(-reach, reach + 1)[:, None], 0, H)
    best = contrast[near, np.arange(W)[None, :]].max(axis=0)
    return has & (best < min_contrast)


def otsu_baseline(image: np.ndarray) -> np.ndarray:
    """Baseline: Otsu threshold on brightness + blueness; first non-sky row per column."""
    import cv2

    from ..features.skyline import skyline_of_terrain

    rgb = image.astype(np.float32)
    skyness = 0.5 * rgb.mean(axis=2) + 0.5 * (rgb[..., 2] - rgb[..., 0]) + 128
    skyness = np.clip(skyness, 0, 255).astype(np.uint8)
    _, sky = cv2.threshold(cv2.GaussianBlur(skyness, (5, 5), 0), 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return skyline_of_terrain(sky == 0)


def meets_target(median: float, within5: float) -> bool:
    return median <= TARGET_MEDIAN_PX and within5 >= TARGET_WITHIN5


def method_params(spec: str):
    """SkylineParams of a method spec ``name[@width][/draftN][:ONNX]``: ``hybrid@512`` the network
    run 512 px wide; ``gmm/draft2`` the mixtures' early rounds on every 2nd row and column;
    ``hybrid:old/sky_net.onnx`` another network (its fit beside it, ``sky_net_fit.json``)."""
    from ..features import SkylineParams

    spec, _, weights = spec.partition(":")
    spec, _, draft = spec.partition("/draft")
    name, _, width = spec.partition("@")
    extra = {"net_width": int(width)} if width else {}
    if draft:
        extra["draft_scale"] = int(draft)
    if weights:
        extra["net_weights"] = weights
    return SkylineParams(method=name, **extra)


def evaluate(items, methods: list[str], progress: bool = True) -> list[dict]:
    """One row per photo: per method median px, within-5 share, seconds; confidence split."""
    from ..features import extract_skyline, load_photo

    rows = []
    for k, it in enumerate(items):
        image = load_photo(it.image_path)
        truth = it.truth_skyline()
        row = {"photo": it.key, "width": int(image.shape[1]), "height": int(image.shape[0])}
        for method in methods:
            t = time.perf_counter()
            if method == "otsu":
                skyline, confidence = otsu_baseline(image), None
            else:
                result = extract_skyline(image, method_params(method))
                skyline, confidence = result.skyline, result.confidence
            seconds = time.perf_counter() - t
            e = column_errors(skyline, truth)
            row[method] = {"median": float(np.median(e)), "within5": float(np.mean(e <= 5)), "seconds": seconds}
            if method == methods[0] and confidence is not None:
                c = confidence[np.isfinite(truth)]
                row["confident_share"] = float(np.mean(c >= CONFIDENT))
                row["errors_confident"] = e[c >= CONFIDENT].tolist()
                row["errors_doubtful"] = e[c < CONFIDENT].tolist()
        row["unseen"] = float(np.mean(truth_without_edge(image, truth)[np.isfinite(truth)]))
        rows.append(row)
        if progress:
            print(f"  [{k + 1}/{len(items)}] {it.key}: " + ", ".join(
                f"{m} {row[m]['within5'] * 100:.1f} %" for m in methods), flush=True)
    return rows


def summary(rows: list[dict], method: str, place_of: dict[str, str] | None = None) -> dict:
    """A method's figures over ``rows``; with ``place_of`` (photo key -> place, :func:`split_places`; a photo it
    lacks is a place of its own) also the 95 % intervals of the share meeting the target and of the mean share within
    5 px with the places resampled whole (:func:`~skyrender.evaluate.place_interval`)."""
    w = np.array([r[method]["within5"] for r in rows])
    med = np.array([r[method]["median"] for r in rows])
    sec = np.array([r[method]["seconds"] for r in rows])
    met = np.array([meets_target(a, b) for a, b in zip(med, w)])
    out = {"photos": len(rows), "met": int(met.sum()), "met_share": float(met.mean()), "mean_within5": float(w.mean()),
           "min_within5": float(w.min()), "median_seconds": float(np.median(sec)), "max_seconds": float(sec.max())}
    if place_of is not None:
        labels = [place_of.get(r["photo"], r["photo"]) for r in rows]
        out["places"] = len(set(labels))
        out["met_share_interval"] = list(place_interval(met, labels))
        out["mean_within5_interval"] = list(place_interval(w, labels))
    return out


def unchanged_report(now: dict, bench: dict, sides=("validation", "heldout"), method: str = "select") -> str:
    """Photo by photo, ``now`` (``{photo: {"median", "within5"}}``, another run of ``method``) against a
    committed ``bench-skyline.json`` (``bench``) on ``sides``: how many photos have the same median error and
    share of columns within 5 px, then one line per photo that does not (an identity check after a change)."""
    same, differ = 0, []
    for side in sides:
        for p in bench["sides"][side]["photos"]:
            a, b = p[method], now[p["photo"]]
            if a["median"] == b["median"] and a["within5"] == b["within5"]:
                same += 1
            else:
                differ.append(f"  {p['photo']}: {a} -> {b}")
    return "\n".join([f"bench-skyline.json at {bench['commit']}: {same} of {same + len(differ)} photos with the same "
                      "median and share within 5 px", *differ])


def confidence_summary(rows: list[dict]) -> dict | None:
    if not rows or "errors_confident" not in rows[0]:
        return None
    conf = np.concatenate([r["errors_confident"] for r in rows])
    doubt = np.concatenate([r["errors_doubtful"] for r in rows])
    out = {"confident_columns": int(len(conf)), "doubtful_columns": int(len(doubt))}
    for name, e in (("confident", conf), ("doubtful", doubt)):
        out[f"{name}_within5"] = float(np.mean(e <= 5)) if len(e) else None
        out[f"{name}_median_px"] = float(np.median(e)) if len(e) else None
    return out


def format_table(rows: list[dict], methods: list[str]) -> str:
    head = f"{'photo':40s}" + "".join(f" | {m + ' med':>9s} {'<=5px':>6s} {'s':>5s}" for m in methods) + " | unseen"
    lines = [head]
    for r in rows:
        cells = "".join(f" | {r[m]['median']:9.2f} {100 * r[m]['within5']:5.1f}% {r[m]['seconds']:5.2f}" for m in methods)
        miss = "" if meets_target(r[methods[0]]["median"], r[methods[0]]["within5"]) else "  (target missed)"
        lines.append(f"{r['photo']:40s}{cells} | {100 * r['unseen']:5.1f}%{miss}")
    return "\n".join(lines)


def speed(items, method: str = "hybrid", repeats: int = 3) -> dict:
    """Seconds of an extractor (median of ``repeats``, after a warm-up) on a
    1024-wide photo and on a 12-megapixel copy of it (4x up-scaled, 4096 x 3072), and the
    12-MP copy's median error against the 4x truth."""
    import cv2

    from ..features import extract_skyline, load_photo

    net = method_params(method)
    it = next(i for i in items if i.key.startswith("ch1/"))
    image = load_photo(it.image_path)
    big = cv2.resize(image, (image.shape[1] * 4, image.shape[0] * 4), interpolation=cv2.INTER_CUBIC)
    out = {"photo": it.key, "method": method}
    for name, img in (("1024", image), ("12mp", big)):
        extract_skyline(img, net)
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            result = extract_skyline(img, net)
            times.append(time.perf_counter() - t)
        scale = img.shape[1] / image.shape[1]
        e = column_errors(result.skyline, np.repeat(it.truth_skyline(), scale) * scale) / scale
        out[name] = {"width": int(img.shape[1]), "height": int(img.shape[0]), "seconds": float(np.median(times)),
                     "median_px_at_1024": float(np.median(e))}
    return out


def mixture_fit_speed(items, repeats: int = 3) -> dict:
    """Seconds of the colour mixtures' EM (:func:`~skyrender.features.sky._fit_gmm`) against
    scikit-learn's ``GaussianMixture`` with the same settings (the photo extractor's budget,
    :data:`~skyrender.features.skyline.SELECT_MIXTURE_BUDGET`), on the same samples (that many pixels
    of the top third and of the bottom half of a CH1 photo, as the mixtures' first round picks
    them), median of ``repeats`` after a warm-up, one thread each; and the largest difference
    between their fitted means."""
    from sklearn.mixture import GaussianMixture
    from threadpoolctl import threadpool_limits

    from ..features import load_photo
    from ..features.sky import GMM_MAX_ITER, GMM_REG_COVAR, _fit_gmm, mixture_inputs, pixel_features
    from ..features.skyline import SELECT_MIXTURE_BUDGET

    tol, n_samples = SELECT_MIXTURE_BUDGET
    it = next(i for i in items if i.key.startswith("ch1/"))
    features = pixel_features(load_photo(it.image_path))
    H, W = features.shape[:2]
    x = mixture_inputs(features)
    rng = np.random.default_rng(0)
    top, bottom = x[: H // 3 * W], x[H // 2 * W:]
    sets = [top[rng.choice(len(top), n_samples, replace=False)], bottom[rng.choice(len(bottom), n_samples, replace=False)]]

    def ours(samples):
        return _fit_gmm(samples, 5, 0, tol).means

    def theirs(samples):
        with threadpool_limits(1):
            return GaussianMixture(5, covariance_type="full", reg_covar=GMM_REG_COVAR, max_iter=GMM_MAX_ITER,
                                   tol=tol, random_state=0).fit(samples).means_

    out = {"photo": it.key, "samples": n_samples, "tol": tol}
    for name, fit in (("ours", ours), ("scikit_learn", theirs)):
        means = [fit(s) for s in sets]
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            for s in sets:
                fit(s)
            times.append((time.perf_counter() - t) / len(sets))
        out[name] = {"seconds": float(np.median(times)), "means": means}
    out["max_mean_difference"] = float(max(np.abs(a - b).max() for a, b in zip(out["ours"].pop("means"),
                                                                              out["scikit_learn"].pop("means"))))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=DEFAULT_PHOTOS)
    parser.add_argument("--sides", nargs="+", default=["validation", "heldout"],
                        choices=["train", "dev", "validation", "heldout"])
    parser.add_argument("--methods", nargs="+", default=["select", "hybrid", "net", "gmm", "otsu"],
                        choices=["select", "hybrid", "net", "gmm", "otsu"])
    parser.add_argument("--limit", type=int, default=0, help="at most this many photos per side (0: all)")
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "photos"))
    parser.add_argument("--retable", action="store_true",
                        help="rewrite the text (and the summaries) of the run in OUT/bench-skyline.json without extracting")
    args = parser.parse_args(argv)
    if args.retable:
        try:
            with open(os.path.join(args.out, "bench-skyline.json")) as f:
                report = json.load(f)
        except (OSError, ValueError) as exc:
            print(f"--retable: cannot read {os.path.join(args.out, 'bench-skyline.json')}: {exc}")
            return 2
        return _write(with_summaries(report), args.out)
    if not os.path.isdir(args.data):
        print(f"no photos at {args.data}")
        return 2
    report = {"commit": git_commit(), "cpus": os.cpu_count(), "cpu_model": cpu_description(), "versions": library_versions(),
              "methods": args.methods, "sides": {}}
    for side in args.sides:
        items = items_on_side(side, args.data)
        if args.limit:
            items = items[: args.limit]
        print(f"{side}: {len(items)} photos", flush=True)
        rows = evaluate(items, args.methods)
        report["sides"][side] = {"photos": rows, "confidence": confidence_summary(rows)}
    timed = next((m for m in args.methods if m != "otsu"), "select")  # the first extractor (Otsu is a baseline)
    report["speed"] = speed(items_on_side("validation", args.data) or items_on_side("train", args.data), timed)
    report["mixture_fit"] = mixture_fit_speed(items_on_side("validation", args.data) or items_on_side("train", args.data))
    for r in report["sides"].values():  # column lists are for the summary only
        for p in r["photos"]:
            p.pop("errors_confident", None)
            p.pop("errors_doubtful", None)
    return _write(with_summaries(report), args.out)


def with_summaries(report: dict) -> dict:
    """``report`` (what :func:`main` writes to ``bench-skyline.json``) with each side's summaries made from its rows,
    with the places' intervals (:func:`summary`; so an older run retabled gains them)."""
    place_of = split_places()
    for data in report["sides"].values():
        data["summary"] = {m: summary(data["photos"], m, place_of) for m in report["methods"]}
    return report


def report_text(report: dict) -> str:
    """The tables and summary lines of a run with its summaries (:func:`with_summaries`)."""
    methods, text = report["methods"], []
    for side, data in report["sides"].items():
        rows, sums, conf = data["photos"], data["summary"], data.get("confidence")
        text.append(f"## {side} ({len(rows)} photos)\n\n{format_table(rows, methods)}\n")
        for m, s in sums.items():
            text.append(f"{m:5s}: target (median <= {TARGET_MEDIAN_PX} px and >= {100 * TARGET_WITHIN5:.0f} % within 5 px) met "
                        f"on {s['met']} of {s['photos']} ({100 * s['met_share']:.0f} %); mean within 5 px "
                        f"{100 * s['mean_within5']:.1f} %; lowest {100 * s['min_within5']:.1f} %; seconds median "
                        f"{s['median_seconds']:.2f}, max {s['max_seconds']:.2f}")
            text.append(f"       95 % interval with the {s['places']} places resampled whole: target met "
                        f"{100 * s['met_share_interval'][0]:.0f}-{100 * s['met_share_interval'][1]:.0f} %, mean within 5 px "
                        f"{100 * s['mean_within5_interval'][0]:.1f}-{100 * s['mean_within5_interval'][1]:.1f} %")
        if conf:
            text.append(f"confidence >= {CONFIDENT}: {conf['confident_columns']} columns, "
                        f"{100 * conf['confident_within5']:.1f} % within 5 px (median {conf['confident_median_px']:.2f} px); "
                        f"below: {conf['doubtful_columns']} columns, "
                        + (f"{100 * conf['doubtful_within5']:.1f} % within 5 px (median {conf['doubtful_median_px']:.2f} px)"
                           if conf["doubtful_columns"] else "none"))
        text.append("")
    sp, fits = report["speed"], report["mixture_fit"]
    text.append(f"speed of {sp['method']} ({sp['photo']}, median of 3): {sp['1024']['width']} x {sp['1024']['height']}: "
                f"{sp['1024']['seconds']:.2f} s; {sp['12mp']['width']} x {sp['12mp']['height']} (12.6 MP): "
                f"{sp['12mp']['seconds']:.2f} s, median error {sp['12mp']['median_px_at_1024']:.2f} px at 1024 scale "
                f"({sp['1024']['median_px_at_1024']:.2f} px on the 1024 original)")
    text.append(f"colour mixture fit ({fits['photo']}, {fits['samples']} samples, tolerance {fits.get('tol', 1e-3):g}, "
                "median of 3): "
                f"{fits['ours']['seconds']:.3f} s against scikit-learn's GaussianMixture "
                f"{fits['scikit_learn']['seconds']:.3f} s ({fits['scikit_learn']['seconds'] / fits['ours']['seconds']:.1f}x), "
                f"means apart by at most {fits['max_mean_difference']:.1e}")
    return "\n".join(text)


def _write(report: dict, out_dir: str) -> int:
    """Print the run's text and write it and its JSON to ``out_dir``; 0."""
    text = report_text(report)
    print(text)
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "bench-skyline.json"), "w") as f:
        json.dump(report, f, indent=1)
    with open(os.path.join(out_dir, "bench-skyline.txt"), "w") as f:
        f.write(f"commit {report['commit']}, {machine_line(report)}\n\n{text}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
