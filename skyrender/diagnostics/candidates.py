"""Where the real-photo localizer loses the truth: the far-horizon search's recall.

``python -m skyrender.diagnostics.candidates [--side train] [--limit N] [--true-skyline]``

For each CH1 photo of a side (the training side by default: never the validation side
for development), with its focal length known, against the SRTM mosaic of its place
(:func:`skyrender.benchmarks.real_localize.place_window`, the photo preset's model):

- the far-horizon poses the photo preset generates (every tilt and window, before
  verification), their distance to the true position;
- the rank of the best-placed pose by the search's own cost and by the verification
  score (the ranks the localizer refines from: the best 8 by each), for poses within
  250 m, 500 m and 1 km of the truth; ``-`` where no pose is that close;
- with ``--true-skyline`` the same from the photo's true skyline (its mask): what a
  perfect skyline extractor would give.

A photo whose truth has no pose within 1 km is lost by the search (grid, near ridges,
tilt, the cost); one with such a pose ranked beyond the 8th is lost by the ranking.
Writes ``experiments/ch1/candidates-<side>.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace

import numpy as np

RADII_M = (250.0, 500.0, 1000.0)
REFINED_PER_RANKING = 8  # the photo preset refines the best 8 by each ranking


def first_rank(order: np.ndarray, distance: np.ndarray, radius: float) -> int | None:
    """1-based rank in ``order`` (indices, best first) of the first pose within ``radius`` m."""
    hit = np.flatnonzero(distance[order] <= radius)
    return int(hit[0]) + 1 if len(hit) else None


def far_horizon_candidates(model, dem, terrain, sky: np.ndarray, weights: np.ndarray, intrinsics, height: float,
                           params):
    """The far-horizon poses the photo preset (``params``) generates for a skyline (every tilt and window, on the
    standable centres, before verification) and their rankings: (poses (K, 6), the search's cost (K,),
    verification score (K,), trusted score (K,))."""
    from ..localizer.horizon_search import horizon_poses, standable_centres
    from ..localizer.verification import verify_poses

    poses, cost = horizon_poses(model.horizons, sky, weights, intrinsics, dem, height, params.horizon,
                                centres=standable_centres(model.horizons, dem, params.max_ground_slope_deg))
    score, trusted = verify_poses(terrain, poses, intrinsics, sky, weights, params.verify_stride, params=params.score)
    return poses, cost, score, trusted


def probe(items, true_skyline: bool = False, progress: bool = True, params=None, rerank: int = 0,
          model_params=None) -> list[dict]:
    from ..benchmarks.real_localize import with_place
    from ..camera import Intrinsics
    from ..features import extract_skyline, load_photo
    from ..localizer import LocalizeParams
    from ..localizer.pipeline import column_weights, rerank_far_horizon

    params = params or LocalizeParams.for_photos()
    rows = []
    for n, it, (dem, terrain, model) in with_place(items, model_params):
        t = time.perf_counter()
        image = load_photo(it.image_path)
        H, W = image.shape[:2]
        if true_skyline:
            sky, weights = it.truth_skyline(), np.ones(W)
        else:
            extracted = extract_skyline(image, params.skyline_params())
            sky, weights = extracted.skyline, column_weights(extracted.confidence, params.confidence_power)
        k = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
        poses, cost, score, trusted = far_horizon_candidates(model, dem, terrain, sky, weights, k, 2.0, params)
        tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
        distance = np.hypot(poses[:, 0] - tx, poses[:, 1] - ty)
        nearest = np.hypot(model.horizons.centres[:, 0] - tx, model.horizons.centres[:, 1] - ty).min()
        row = {"photo": it.key, "poses": int(len(poses)), "nearest_pose_m": float(distance.min()) if len(poses) else None,
               "nearest_centre_m": float(nearest), "seconds": time.perf_counter() - t}
        rankings = [("cost", cost), ("score", score), ("trusted", trusted)]
        if rerank:  # the best ``rerank`` by score and by cost, each rescored by a local position search
            t_r = time.perf_counter()
            both, _, rescored = rerank_far_horizon(terrain, poses, score, cost, k, 2.0, sky, weights,
                                                   replace(params, horizon_rerank=rerank))
            local = np.full(len(poses), np.inf)
            local[both] = rescored
            rankings.append(("local", local))
            row["rerank_seconds"] = time.perf_counter() - t_r
        for name, values in rankings:
            order = np.argsort(values, kind="stable")
            row[f"rank_{name}"] = {f"{r:.0f}": first_rank(order, distance, r) for r in RADII_M}
        rows.append(row)
        if progress:
            r1 = {k_: row[f"rank_{k_}"]["1000"] for k_ in ("cost", "score", "trusted", "local") if f"rank_{k_}" in row}
            print(f"  [{n + 1}/{len(items)}] {it.key}: {row['poses']} poses, nearest {row['nearest_pose_m']:.0f} m; "
                  f"rank of the first within 1 km by cost / score / trusted: {r1}", flush=True)
    return rows


def summary(rows: list[dict]) -> dict:
    """Per radius: photos with a pose that close, and with one among the refined ranks."""
    out = {}
    for r in RADII_M:
        key = f"{r:.0f}"
        found = [row for row in rows if row["rank_cost"][key] is not None]
        refined = [row for row in found if any(row[f"rank_{k}"][key] <= REFINED_PER_RANKING
                                               for k in ("cost", "score") if row[f"rank_{k}"][key] is not None)]
        out[key] = {"photos": len(rows), "with_a_pose": len(found), "among_refined": len(refined)}
        if rows and "rank_local" in rows[0]:  # the re-ranking probe: the same refinement budget (16) by it alone
            local = [row["rank_local"][key] or 10**9 for row in found]
            out[key]["among_best16_local"] = sum(r <= 2 * REFINED_PER_RANKING for r in local)
            out[key]["among_best8_local"] = sum(r <= REFINED_PER_RANKING for r in local)
    return out


def main(argv=None) -> int:
    from ..datasets.real_photos import DEFAULT_PHOTOS, REPO, items_on_side
    from ..evaluate import git_commit

    parser = argparse.ArgumentParser(prog="python -m skyrender.diagnostics.candidates", description=__doc__.splitlines()[0])
    parser.add_argument("--side", default="train", choices=["train", "dev", "validation"])
    parser.add_argument("--limit", type=int, default=0, help="at most N photos, spread over the side")
    parser.add_argument("--true-skyline", action="store_true", help="the photo's true skyline instead of the extracted one")
    parser.add_argument("--set", default=None, metavar="JSON", help="overrides of the photo preset (a probe)")
    parser.add_argument("--model-set", default=None, metavar="JSON",
                        help="overrides of the photo preset's model parameters (a probe; its own cached models)")
    parser.add_argument("--rerank", type=int, default=0, metavar="K",
                        help="probe: also rank the best K by score and by cost after a local position search")
    parser.add_argument("--tag", default="", help="output file candidates-<side>[-true]-<tag>.json")
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "ch1"))
    args = parser.parse_args(argv)
    from ..benchmarks.real_localize import model_overrides
    from ..localizer import LocalizeParams

    params = LocalizeParams.for_photos()
    try:
        if args.set:
            params = LocalizeParams.from_dict(json.loads(args.set), params)
        model_params = model_overrides(args.model_set)
    except ValueError as exc:  # bad JSON or an unknown field: one line, status 2
        print(f"--set / --model-set: {exc}")
        return 2
    if not os.path.isdir(DEFAULT_PHOTOS):
        print(f"no photos at {DEFAULT_PHOTOS}")
        return 2
    items = [it for it in items_on_side(args.side) if it.key.startswith("ch1/")]
    if args.limit:
        items = items[:: max(1, len(items) // args.limit)][: args.limit]
    rows = probe(items, args.true_skyline, params=params, rerank=args.rerank, model_params=model_params)
    s = summary(rows)
    for key, v in s.items():
        print(f"within {key} m: a pose for {v['with_a_pose']} of {v['photos']} photos; among the refined "
              f"(best {REFINED_PER_RANKING} by cost or score) for {v['among_refined']}"
              + (f"; best 8 / 16 after the local search: {v['among_best8_local']} / {v['among_best16_local']}"
                 if "among_best16_local" in v else ""))
    tag = f"{args.side}{'-true' if args.true_skyline else ''}{'-' + args.tag if args.tag else ''}"
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, f"candidates-{tag}.json"), "w") as f:
        json.dump({"commit": git_commit(), "side": args.side, "true_skyline": args.true_skyline, "set": args.set,
                   "model_set": args.model_set, "summary": s,
                   "photos": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
