"""Which far-horizon poses does the fov-unknown re-ranking need to move? Could fewer be moved?

``python experiments/ch1/rerank-screen/screen_recall.py --photos N > experiments/ch1/rerank-screen/screen_recall.txt``

Training side only (CH1 train and dev photos of the fov-unknown set, ``../dem-window/unknown/``), fov unknown, photo
preset. Each photo is localized as shipped; at every call of the re-ranking (one per best-fitting fov) its poses are
also screened: moved on a coarser grid (``local_rescore``: grid over the same +-300 m, columns rendered every
stride-th at 1,024 wide) as a cheap first pass could be, and the arrays are kept (``--out``, an npz). Printed per
call: the rank, by the full re-ranking's score, of the best pose it moves to within 1 km of the true position (a
right place; - where none), and that pose's rank by the search's score before moving, by its cost (the second
ranking) and by each screen's score: a screen (or a plain cut of the poses by their first rankings,
``horizon_rerank``) keeping that many by either ranking would keep the right place.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from skyrender.benchmarks import real_localize
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.localizer import LocalizeParams, pipeline
from skyrender.localizer.refinement import local_rescore

SCREENS = [(3, 32), (3, 64), (5, 64)]


def fov_unknown_photos() -> list[str]:
    names = []
    for side in ("train", "dev"):
        with open(f"experiments/ch1/dem-window/unknown/bench-real-{side}-unknown-{side}.json") as f:
            names += [r["photo"] for r in json.load(f)["photos"]]
    return names


def rank_of(values: np.ndarray, i: int) -> int:
    """1-based rank of ``values[i]`` (ascending, ties by index as the pipeline breaks them)."""
    return int(np.flatnonzero(np.argsort(values, kind="stable") == i)[0]) + 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", type=int, default=8)
    parser.add_argument("--out", default="/tmp/rerank-screen-calls.npz")
    args = parser.parse_args()
    wanted = fov_unknown_photos()
    items = [it for side in ("train", "dev") for it in items_on_side(side) if it.key in wanted]
    chosen = items[:: max(1, len(items) // args.photos)][: args.photos]
    full = pipeline.rerank_far_horizon
    calls, arrays = [], {}

    def recorded(terrain, poses, score, second, intrinsics, height, sky, weights, params):
        t = time.perf_counter()
        out = full(terrain, poses, score, second, intrinsics, height, sky, weights, params)
        record = {"full_s": time.perf_counter() - t, "screen_s": [], "screened": []}
        for grid, stride in SCREENS:
            t = time.perf_counter()
            _, s = local_rescore(terrain, poses, intrinsics, height, sky, weights, params.rerank_half_m, grid,
                                 max(1, round(stride * intrinsics.width / 1024)), params.score)
            record["screen_s"].append(time.perf_counter() - t)
            record["screened"].append(s)
        record.update(poses=poses, moved=out[1], rescored=out[2], score=score, second=second, pick=out[0])
        calls.append(record)
        return out

    pipeline.rerank_far_horizon = recorded
    params = LocalizeParams.for_photos()
    print(f"commit {git_commit()}; {len(chosen)} training-side CH1 photos, fov unknown, photo preset; per re-ranking "
          f"call: the best right place's rank (1-based) by the full re-ranking, and by the first rankings and screens")
    print(f"{'photo':26s} {'poses':>5s} {'full s':>6s} {'full':>5s} {'score':>5s} {'cost':>5s} "
          + " ".join(f"{str(s):>9s}" for s in SCREENS) + "  screen s")
    n_call = 0
    for it in chosen:
        calls.clear()
        rows = real_localize.run([it], ["unknown"], progress=False, params=params)
        truth = np.array(rows[0]["truth_xy"])
        for c in calls:
            assert np.array_equal(c["pick"], np.arange(len(c["poses"])))  # the preset moves every pose
            right = np.flatnonzero(np.hypot(*(c["moved"][:, :2] - truth).T) < 1000.0)
            if len(right):
                i = right[np.argmin(c["rescored"][right])]
                ranks = [rank_of(c["rescored"], i), rank_of(c["score"], i), rank_of(c["second"], i)]
                ranks += [rank_of(s, i) for s in c["screened"]]
                cells = " ".join(f"{r:>5d}" for r in ranks[:3]) + " " + " ".join(f"{r:>9d}" for r in ranks[3:])
            else:
                cells = " ".join(f"{'-':>5s}" for _ in range(3)) + " " + " ".join(f"{'-':>9s}" for _ in SCREENS)
            print(f"{it.key[4:30]:26s} {len(c['poses']):5d} {c['full_s']:6.1f} {cells}  "
                  + " ".join(f"{s:.1f}" for s in c["screen_s"]), flush=True)
            for key in ("poses", "moved", "rescored", "score", "second"):
                arrays[f"{n_call}_{key}"] = c[key]
            for n, s in enumerate(c["screened"]):
                arrays[f"{n_call}_screen{n}"] = s
            arrays[f"{n_call}_truth"] = truth
            arrays[f"{n_call}_photo"] = np.array(it.key)
            n_call += 1
        np.savez_compressed(args.out, **arrays)


if __name__ == "__main__":
    main()
