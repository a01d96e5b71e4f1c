"""The answer's focal length refitted within a fraction of the given one, on stored answers (2026-12-05, session 15).

``python experiments/ch1/exif-fov/polish_probe.py ROWS.json OUT.json [--range 0.1] [--side train]``

``ROWS.json``: a ``bench-real`` run's JSON (``photos``) or the confidence's training rows (``rows``), fov known.
For each row localized with refined poses, its answer (the best-scoring refined pose) is fitted once more with the
focal length free within ``--range`` of the given one (:func:`skyrender.localizer.refinement.polish_focal`, what
``LocalizeParams.polish_focal_range`` does after the answer is chosen); printed per photo: the error to the truth
before and after, the fitted focal length over the given one and the scores; then the summary.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, places_of, refined_of, with_terrain
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.localizer import LocalizeParams
from skyrender.localizer.refinement import polish_focal


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("rows")
    ap.add_argument("out")
    ap.add_argument("--range", type=float, default=0.1)
    ap.add_argument("--sides", nargs="+", default=["train", "dev"])
    args = ap.parse_args()
    with open(args.rows) as f:
        data = json.load(f)
    rows = [r for r in data.get("photos") or data.get("rows") if r.get("fov_mode", "known") == "known"]
    items = {it.key: it for side in args.sides for it in items_on_side(side) if it.key.startswith("ch1/")}
    place_of, _ = places_of(items.values())
    rows = sorted((r for r in rows if len(refined_of(r))), key=lambda r: (place_of[r["photo"]], r["photo"]))
    params = LocalizeParams.for_photos()
    out = []
    for row, it, terrain in with_terrain(rows, items):
        image, sky, weights = photo_skyline(it, params)
        H, W = image.shape[:2]
        poses = refined_of(row)
        best = poses[int(np.argmin(poses[:, 7]))]
        k = Intrinsics(W, H, float(it.focal_px), W / 2.0, H / 2.0)
        r = polish_focal(terrain, best[:6], best[6], k, row.get("height_m", 2.0), sky, weights,
                         focal_range=args.range, params=params.score, refine=params.refine)
        truth = np.asarray(row["truth_xy"])
        rec = {"photo": row["photo"], "place": place_of[row["photo"]], "confidence": row.get("confidence"),
               "error_m": float(math.hypot(*(best[:2] - truth))), "polished_error_m": float(math.hypot(*(r.pose[:2] - truth))),
               "f_ratio": float(r.f_px / it.focal_px), "score": float(best[7]), "polished_score": float(r.score)}
        out.append(rec)
        print(f"{rec['photo']:34s} {rec['place']:8s} {rec['error_m']:9.0f} -> {rec['polished_error_m']:9.0f} m  "
              f"f x{rec['f_ratio']:.3f}  score {rec['score']:.3f} -> {rec['polished_score']:.3f}", flush=True)
    right = [r for r in out if r["error_m"] <= 1000.0]
    crossed = [r["photo"] for r in out if (r["error_m"] <= 1000.0) != (r["polished_error_m"] <= 1000.0)]
    before = float(np.median([r["error_m"] for r in right])) if right else float("nan")
    after = float(np.median([r["polished_error_m"] for r in right])) if right else float("nan")
    closer = sum(r["polished_error_m"] < r["error_m"] for r in right)
    summary = {"commit": git_commit(), "range": args.range, "photos": len(out), "within_1km": len(right),
               "crossed_1km": crossed, "median_error_within_1km": [before, after], "closer": closer,
               "within_250m": [sum(r["error_m"] <= 250 for r in out), sum(r["polished_error_m"] <= 250 for r in out)],
               "within_100m": [sum(r["error_m"] <= 100 for r in out), sum(r["polished_error_m"] <= 100 for r in out)]}
    print(json.dumps(summary))
    with open(args.out, "w") as f:
        json.dump({"summary": summary, "photos": out}, f, indent=1)


if __name__ == "__main__":
    main()
