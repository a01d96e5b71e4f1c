"""Does the photo show an edge where a place's rendered skyline runs above the extracted one? (a probe on stored
refined poses, 2026-12-07, session 33)

``python experiments/ch1/edge-support/probe.py OUT.json [--places 4]``

Where the extractor takes a pale far ridge for sky, the extracted line runs below the true skyline, and the right
place's render runs above it there; so does a wrong place's render wherever it puts terrain in the sky. At the right
place the photo should show the faint ridge's edge along the render; at a wrong one, in the open sky, mostly none.
For each of the 73 training-side rows (the shipped confidence's rows, fov known) the best ``--places`` distinct places
among the refined poses are rendered (:func:`~skyrender.benchmarks.real_localize.stored_places`), and in every column
where a render runs more than 3 px above the extracted line, the photo's vertical Lab gradient is read within 2 px of
the rendered row. A column is *supported* where that gradient beats the photo's own sky clutter (a percentile of the
gradient over pixels more than 5 px above the extracted line). Scores:

- ``plain``: the photo preset's score of each render against the extracted line;
- ``edge pNN``: the same with the photo's line moved up to the render in the supported columns (the render taken as
  the skyline where the photo shows an edge there), the sky clutter's NNth percentile the threshold.

Reported (``place_report``): photos whose best-scoring place lies within 1 km, and the margins; and per place kind
(right, within 1 km, or wrong) the share of its above-the-line columns supported.
"""

from __future__ import annotations

import argparse

import cv2
import numpy as np

from skyrender.benchmarks.real_localize import place_report, stored_places
from skyrender.features import load_photo
from skyrender.localizer import LocalizeParams
from skyrender.localizer.verification import score_skylines

PERCENTILES = (90, 95, 98)
LINE_SHARES = (0.15, 0.25, 0.4)  # thresholds as shares of the extracted line's own edge strength (median)
ABOVE_PX = 6.0  # a render this far above the extracted line is a disputed column
CLEAR_PX = 4  # the edge looked for no nearer than this to the extracted line (its own edge spreads that far)
REACH_PX = 2  # the edge looked for within this many rows of the rendered row
SKY_MARGIN_PX = 5  # sky clutter measured this far above the extracted line


def vertical_gradient(image: np.ndarray) -> np.ndarray:
    """(H, W) float32 magnitude of the vertical derivative of CIE Lab (L, a, b in their usual units; Sobel 3x3 / 8,
    units per px) of an RGB uint8 photo, lightly smoothed first."""
    lab = cv2.cvtColor(cv2.GaussianBlur(image, (3, 3), 0).astype(np.float32) / 255.0, cv2.COLOR_RGB2LAB)
    gy = cv2.Sobel(lab, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    return np.sqrt((gy ** 2).sum(axis=2))


def support(grad: np.ndarray, rendered: np.ndarray, sky: np.ndarray, threshold: float) -> np.ndarray:
    """(P, W) bool: the render runs above the extracted line and the photo shows an edge within REACH_PX of it (no
    nearer than CLEAR_PX to the extracted line)."""
    H, W = grad.shape
    r = np.nan_to_num(rendered, nan=H)
    s = np.nan_to_num(sky, nan=H)[None, :]
    above = r < s - ABOVE_PX
    best = np.zeros(r.shape, np.float32)
    cols = np.arange(W)[None, :]
    for dv in range(-REACH_PX, REACH_PX + 1):
        v = np.round(r).astype(int) + dv
        ok = (v >= 0) & (v < s - CLEAR_PX)
        best = np.maximum(best, np.where(ok, grad[np.clip(v, 0, H - 1), np.broadcast_to(cols, v.shape)], 0.0))
    return above & (best > threshold)


def thresholds_of(grad: np.ndarray, sky: np.ndarray) -> dict[str, float]:
    """The support thresholds of a photo: percentiles of its sky clutter (gradient more than SKY_MARGIN_PX above the
    extracted line) and shares of the extracted line's own median edge strength."""
    H, W = grad.shape
    sky_px = np.arange(H)[:, None] < np.nan_to_num(sky, nan=H)[None, :] - SKY_MARGIN_PX
    on_line = np.isfinite(sky) & (sky >= 1) & (sky < H - 1)
    cols = np.flatnonzero(on_line)
    line_strength = float(np.median(np.maximum.reduce([grad[np.clip(np.round(sky[on_line]).astype(int) + d, 0, H - 1), cols]
                                                       for d in (-1, 0, 1)]))) if on_line.any() else np.inf
    out = {f"p{p}": float(np.percentile(grad[sky_px], p)) if sky_px.any() else np.inf for p in PERCENTILES}
    out.update({f"line{x}": x * line_strength for x in LINE_SHARES})
    return out


def edge_scores(grad, rendered, sky, weights, score_params, threshold) -> tuple[np.ndarray, np.ndarray]:
    """(P,) scores of renders (P, W) against the extracted line moved up to each render where it is supported, and
    (P,) how many columns were supported."""
    ok = support(grad, rendered, sky, threshold)
    scores = [score_skylines(rendered[i][None], np.where(ok[i], rendered[i], sky), weights, score_params,
                             agreement=False)[0][0] for i in range(len(rendered))]
    return np.array(scores, float), ok.sum(axis=1)


def truth_ceiling(arrays: str, rows_files: list[str], out_path: str) -> None:
    """The truth against the answer under each score, from ``truth_refine --arrays`` (a photo's rendered refined
    poses, the answer first, then the truth's pinned and freely refined poses) and its rows (for the verdicts)."""
    import glob
    import json
    import os

    from skyrender.datasets.real_photos import items_on_side

    rows = {r["photo"]: r for f in rows_files for r in json.load(open(f))["photos"]}
    items = {it.key: it for side in ("train", "dev") for it in items_on_side(side)}
    params = LocalizeParams.for_photos()
    out = []
    for path in sorted(glob.glob(os.path.join(arrays, "*.npz"))):
        z = np.load(path)
        key = "ch1/" + os.path.basename(path)[len("ch1_"):-len(".npz")]
        row, it = rows[key], items[key]
        grad = vertical_gradient(load_photo(it.image_path))
        sky, weights, rendered, dist = z["sky"], z["weights"], z["rendered"], z["distance_to_truth"]
        n = len(rendered) - 2  # the refined poses; the truth's two last
        truth_ok = np.array([True, dist[-1] <= 1000])
        rec = {"photo": key, "verdict": row["verdict"], "scores": {}}
        variants = {"plain": None, **thresholds_of(grad, sky)}
        for name, threshold in variants.items():
            if threshold is None:
                s = score_skylines(rendered, sky, weights, params.score, agreement=False)[0]
            else:
                s, _ = edge_scores(grad, rendered, sky, weights, params.score, threshold)
            wrong = s[:n][dist[:n] > 1000]
            near = s[:n][dist[:n] <= 1000]
            rec["scores"][name] = {"best_wrong": float(wrong.min()) if len(wrong) else None,
                                   "best_near_refined": float(near.min()) if len(near) else None,
                                   "truth": float(s[n:][truth_ok].min())}
        out.append(rec)
        print(key, row["verdict"], {k: (round(v["truth"], 2), round(v["best_wrong"], 2) if v["best_wrong"] else None)
                                    for k, v in rec["scores"].items()}, flush=True)
    json.dump(out, open(out_path, "w"), indent=1)
    for name in out[0]["scores"]:
        wins = [r["photo"] for r in out if r["scores"][name]["best_wrong"] is not None
                and r["scores"][name]["truth"] < r["scores"][name]["best_wrong"]]
        print(f"{name:10s}: the truth fits better than every wrong refined place on {len(wins)} of {len(out)}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--places", type=int, default=4)
    ap.add_argument("--arrays", default=None, help="truth_refine --arrays DIR: the truth against the answer instead")
    ap.add_argument("--rows", nargs="*", default=[], help="with --arrays: truth_refine's JSON files")
    a = ap.parse_args()
    if a.arrays:
        truth_ceiling(a.arrays, a.rows, a.out)
        return
    params = LocalizeParams.for_photos()
    kinds = [f"p{p}" for p in PERCENTILES] + [f"line{x}" for x in LINE_SHARES]
    names = ["plain"] + [f"edge {k}" for k in kinds]
    out = []
    for row, it, sky, weights, places, rendered, _ in stored_places(places=a.places, params=params):
        image = load_photo(it.image_path)
        H, W = image.shape[:2]
        grad = vertical_gradient(image)
        truth = np.asarray(row["truth_xy"])
        dist = [float(np.hypot(*(p[:2] - truth))) for p in places]
        rec = {"photo": it.key, "dist_m": dist, "scores": {}, "above_cols": [], "supported": {}}
        rec["scores"]["plain"] = [float(s) for s in score_skylines(rendered, sky, weights, params.score, agreement=False)[0]]
        r = np.nan_to_num(rendered, nan=H)
        rec["above_cols"] = [int(n) for n in (r < np.nan_to_num(sky, nan=H)[None, :] - ABOVE_PX).sum(axis=1)]
        thresholds = thresholds_of(grad, sky)
        for kind, threshold in thresholds.items():
            scores, n_ok = edge_scores(grad, rendered, sky, weights, params.score, threshold)
            rec["scores"][f"edge {kind}"] = [float(v) for v in scores]
            rec["supported"][kind] = [int(n) for n in n_ok]
            rec.setdefault("threshold", {})[kind] = threshold
        out.append(rec)
        print(it.key, [round(d / 1000, 1) for d in dist], "above", rec["above_cols"], "supported p95 / line0.25",
              rec["supported"]["p95"], rec["supported"]["line0.25"],
              {n: [round(s, 2) for s in v] for n, v in rec["scores"].items()}, flush=True)
    place_report(out, names, a.out)
    for kind in kinds:
        share = {True: [], False: []}
        for rec in out:
            for d, n_above, n_ok in zip(rec["dist_m"], rec["above_cols"], rec["supported"][kind]):
                if n_above >= 10:
                    share[d <= 1000].append(n_ok / n_above)
        print(f"{kind}: supported share of above-the-line columns, median: right places {np.median(share[True]):.2f} "
              f"(n {len(share[True])}), wrong places {np.median(share[False]):.2f} (n {len(share[False])})")


if __name__ == "__main__":
    main()
