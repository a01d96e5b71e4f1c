"""Is the right place beaten by the score, or never reached? The localizer's refined
candidates against refinements started at the TRUE position.

``python -m skyrender.diagnostics.truth_refine [--side dev] [--limit N] [--photos KEY ...] [--true-skyline]``

For each CH1 photo of a side (the dev side by default; never the validation side for
development), its focal length known, against the SRTM mosaic of its place (the photo
preset's model, as ``make bench-real``):

1. the photo preset localizes it without abstaining; every refined candidate's position
   and refined score (``LocalizeStats.refined_poses``) and its distance to the truth;
2. at the TRUE position (camera 2 m above the DEM), the best 3 orientations (10 deg of pan
   apart) over pan (2 deg) x tilt (-10..30 deg, 5 deg), aligned as the verification aligns,
   against the photo's TRUE skyline (its mask: the extracted one can be tens of px off), each
   refined against the extracted skyline with the photo preset's score, the position held
   within metres (``pinned``, the best of the three: local least squares only, what the DEM
   gives at the right place);
3. the photo preset's full refinement started from that pose (``from_truth``: where the
   localizer's own refinement goes from the truth, and its score there).

A photo whose answer is more than 1 km off is lost by the **score** when the truth's
refined scores are no better than the answer's (a candidate at the truth would not win),
by the **search** when one is better (a candidate near it, refined, would have won).
Writes ``experiments/ch1/truth-refine-<side>[-<tag>].json``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace

import numpy as np

WRONG_M = 1000.0
PINNED_LEVELS = ((0.0, 0.0, 1, 1),)  # refinement's local search at the start position only
TRUTH_STARTS = 3  # orientations at the truth refined (the best by the grid can be a wrong pan)


def orientation_at(terrain, x: float, y: float, height: float, k, sky: np.ndarray, weights: np.ndarray,
                   params, n: int = 1) -> np.ndarray:
    """The best ``n`` poses (n, 6) at world (x, y), at least 10 deg of pan apart, over pan (2 deg)
    x tilt (5 deg), each grid pose's rendered skyline aligned to ``sky`` and its orientation
    corrected by the alignment (:func:`local_rescore` without moving it); ``params``:
    LocalizeParams (its score)."""
    from ..localizer.pose_solver import camera_centres
    from ..localizer.refinement import local_rescore

    centre = camera_centres(terrain.dem, np.array([[x, y]]), height)[0]
    pan, tilt = np.meshgrid(np.arange(0.0, 360.0, 2.0), np.arange(-10.0, 30.01, 5.0), indexing="ij")
    poses = np.column_stack([np.tile(centre, (pan.size, 1)), pan.ravel(), tilt.ravel(), np.zeros(pan.size)])
    aligned, score = local_rescore(terrain, poses, k, height, sky, weights, half_m=0.0, n=1,
                                   stride=params.verify_stride, params=params.score)
    picked: list[int] = []
    for j in np.argsort(score, kind="stable"):
        if len(picked) == n:
            break
        if all(abs((aligned[j, 3] - aligned[i, 3] + 180.0) % 360.0 - 180.0) >= 10.0 for i in picked):
            picked.append(int(j))
    return aligned[picked]


def probe_photo(it, dem, terrain, model, params, arrays_to: str | None = None, true_skyline: bool = False) -> dict:
    """Rows 1-3 of the module doc for one photo item; with ``arrays_to`` (a folder) also its
    skylines: the photo's, each refined pose's rendered (answer first), the truth's two last.
    With ``true_skyline`` the photo's skyline is its true one (the mask), every column trusted:
    what is lost by the score then is lost with a perfect extractor too."""
    from ..benchmarks.real_localize import true_extraction
    from ..camera import Intrinsics
    from ..features import extract_skyline, load_photo
    from ..localizer import localize
    from ..localizer.pipeline import column_weights
    from ..localizer.refinement import refine_pose
    from ..render import render_skylines

    t = time.perf_counter()
    image = load_photo(it.image_path)
    H, W = image.shape[:2]
    extracted = true_extraction(it, H) if true_skyline else extract_skyline(image, params.skyline_params())
    sky, weights = extracted.skyline, column_weights(extracted.confidence, params.confidence_power)
    k = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
    tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
    result = localize(image, model, 2.0, k.fov, terrain=terrain, skyline=extracted, params=replace(params, min_confidence=0.0))
    refined = np.array(result.stats.refined_poses, np.float64).reshape(-1, 8)
    distance = np.hypot(refined[:, 0] - tx, refined[:, 1] - ty)
    order = np.argsort(refined[:, 7], kind="stable")
    near = np.flatnonzero(distance[order] <= WRONG_M)
    row = {"photo": it.key, "error_m": float(distance[order[0]]) if len(order) else None,
           "confidence": result.confidence, "answer_score": float(refined[order[0], 7]) if len(order) else None,
           "refined": [{"distance_m": float(distance[j]), "score": float(refined[j, 7])} for j in order],
           "best_near_rank": int(near[0]) + 1 if len(near) else None,
           "best_near_score": float(refined[order[near[0]], 7]) if len(near) else None,
           "localize_seconds": time.perf_counter() - t}
    # oriented by the true skyline (the mask): the extracted one can be off by tens of px
    truth_sky = it.truth_skyline()
    starts = orientation_at(terrain, tx, ty, 2.0, k, truth_sky, np.isfinite(truth_sky).astype(float), params,
                            n=TRUTH_STARTS)
    pinned = min((refine_pose(terrain, start, k, 2.0, sky, weights, f_px=k.f_px, params=params.score,
                              refine=replace(params.refine, search_levels=PINNED_LEVELS)) for start in starts),
                 key=lambda r: r.score)
    free = refine_pose(terrain, pinned.pose, k, 2.0, sky, weights, f_px=k.f_px, params=params.score, refine=params.refine)
    for name, r in (("pinned", pinned), ("from_truth", free)):
        row[name] = {"score": r.score, "moved_m": float(np.hypot(r.pose[0] - tx, r.pose[1] - ty)),
                     "pan": float(r.pose[3]), "tilt": float(r.pose[4]), "swing": float(r.pose[5])}
    row["seconds"] = time.perf_counter() - t
    row["verdict"] = verdict(row)
    if arrays_to:  # what any other score can be tried on: the skylines of every refined pose and of the truth's
        poses = np.r_[refined[order, :6], [pinned.pose, free.pose]]
        f_px = np.r_[refined[order, 6], pinned.f_px, free.f_px]
        rendered, distances = render_skylines(terrain, poses, k, with_distance=True,
                                              per_pose_intrinsics=np.column_stack([f_px, np.full((len(f_px), 2), (k.cx, k.cy))]))
        np.savez_compressed(os.path.join(arrays_to, it.key.replace("/", "_") + ".npz"), sky=sky, weights=weights,
                            confidence=extracted.confidence, truth_sky=truth_sky, rendered=rendered,
                            distance=distances, poses=poses, f_px=f_px,
                            distance_to_truth=np.r_[distance[order], row["pinned"]["moved_m"], row["from_truth"]["moved_m"]])
    return row


def truth_score(row: dict) -> float:
    """The truth's best fit (px): pinned at it, or refined from it while it stays within 1 km."""
    free = row["from_truth"]
    return min(row["pinned"]["score"], free["score"] if free["moved_m"] <= WRONG_M else np.inf)


def verdict(row: dict) -> str:
    """``right`` (answer within 1 km), else ``search`` or ``score`` (module doc)."""
    if row["error_m"] is not None and row["error_m"] <= WRONG_M:
        return "right"
    return "search" if row["answer_score"] is None or truth_score(row) < row["answer_score"] else "score"


def probe(items, params=None, progress: bool = True, arrays_to: str | None = None,
          true_skyline: bool = False) -> list[dict]:
    from ..benchmarks.real_localize import with_place
    from ..localizer import LocalizeParams

    params = params or LocalizeParams.for_photos()
    rows = []
    for n, it, place in with_place(items):
        row = probe_photo(it, *place, params, arrays_to, true_skyline)
        rows.append(row)
        if progress:
            answer = "none" if row["error_m"] is None else f"{row['error_m']:.0f} m at {row['answer_score']:.2f} px"
            print(f"  [{n + 1}/{len(items)}] {it.key}: answer {answer} "
                  f"(confidence {row['confidence']:.2f}); best within 1 km: rank {row['best_near_rank']}, "
                  f"{row['best_near_score']}; truth pinned {row['pinned']['score']:.2f} px, refined from it "
                  f"{row['from_truth']['score']:.2f} px {row['from_truth']['moved_m']:.0f} m away: {row['verdict']}",
                  flush=True)
    return rows


def summary(rows: list[dict]) -> dict:
    out = {v: sum(r["verdict"] == v for r in rows) for v in ("right", "search", "score")}
    out["photos"] = len(rows)
    out["wrong_with_a_near_candidate_refined"] = sum(r["verdict"] != "right" and r["best_near_rank"] is not None
                                                     for r in rows)
    return out


def main(argv=None) -> int:
    from ..datasets.real_photos import DEFAULT_PHOTOS, REPO, items_on_side
    from ..evaluate import git_commit
    from ..localizer import LocalizeParams

    parser = argparse.ArgumentParser(prog="python -m skyrender.diagnostics.truth_refine",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--side", default="dev", choices=["train", "dev", "validation"])
    parser.add_argument("--limit", type=int, default=0, help="at most N photos, spread over the side")
    parser.add_argument("--photos", nargs="+", default=None, help="these photos of the side only")
    parser.add_argument("--set", default=None, metavar="JSON", help="overrides of the photo preset (a probe)")
    parser.add_argument("--tag", default="")
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "ch1"))
    parser.add_argument("--arrays", default=None, metavar="DIR", help="also write each photo's skylines there (.npz)")
    parser.add_argument("--true-skyline", action="store_true",
                        help="localize and fit from each photo's true skyline (its mask), not the extracted one")
    args = parser.parse_args(argv)
    if not os.path.isdir(DEFAULT_PHOTOS):
        print(f"no photos at {DEFAULT_PHOTOS}")
        return 2
    params = LocalizeParams.for_photos()
    if args.set:
        params = LocalizeParams.from_dict(json.loads(args.set), params)
    items = [it for it in items_on_side(args.side) if it.key.startswith("ch1/")]
    if args.photos:
        items = [it for it in items if it.key in set(args.photos)]
    if args.limit:
        items = items[:: max(1, len(items) // args.limit)][: args.limit]
    if args.arrays:
        os.makedirs(args.arrays, exist_ok=True)
    rows = probe(items, params, arrays_to=args.arrays, true_skyline=args.true_skyline)
    s = summary(rows)
    print(f"{s['photos']} photos: {s['right']} answered within 1 km; of the others, lost by the score {s['score']}, "
          f"by the search {s['search']} ({s['wrong_with_a_near_candidate_refined']} with a candidate within 1 km refined)")
    os.makedirs(args.out, exist_ok=True)
    tag = args.side + (f"-{args.tag}" if args.tag else "")
    with open(os.path.join(args.out, f"truth-refine-{tag}.json"), "w") as f:
        json.dump({"commit": git_commit(), "side": args.side, "set": args.set, "true_skyline": args.true_skyline,
                   "summary": s, "photos": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
