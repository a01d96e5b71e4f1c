"""Does a coarse screen before the fov-unknown re-ranking keep the poses the full re-ranking puts first?

``python experiments/ch1/rerank-screen/screen_recall.py --photos N > experiments/ch1/rerank-screen/screen_recall.txt``

Training side only (CH1 train and dev photos of the fov-unknown set, ``../dem-window/unknown/``), fov unknown, photo
preset. Each photo is localized as shipped; every call of the re-ranking (one per best-fitting fov) is also run with
each screen (``LocalizeParams.rerank_screen_fov_unknown``: grid, column stride, poses kept by each ranking) on the
same poses. For each screen: the share of the full re-ranking's best 16 poses by its score that the screen passes on
(those it passes are moved to exactly the same place), and its seconds against the full re-ranking's.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np

from skyrender.benchmarks import real_localize
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.localizer import LocalizeParams, pipeline

SCREENS = [(5, 64, 200), (5, 64, 100), (3, 64, 200), (3, 64, 100), (3, 128, 200)]
TOP = 16


def fov_unknown_photos() -> list[str]:
    names = []
    for side in ("train", "dev"):
        with open(f"experiments/ch1/dem-window/unknown/bench-real-{side}-unknown-{side}.json") as f:
            names += [r["photo"] for r in json.load(f)["photos"]]
    return names


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", type=int, default=8)
    args = parser.parse_args()
    wanted = fov_unknown_photos()
    items = [it for side in ("train", "dev") for it in items_on_side(side) if it.key in wanted]
    chosen = items[:: max(1, len(items) // args.photos)][: args.photos]
    full = pipeline.rerank_far_horizon
    records = []

    def recorded(terrain, poses, score, second, intrinsics, height, sky, weights, params, screen_keep=0):
        t = time.perf_counter()
        out = full(terrain, poses, score, second, intrinsics, height, sky, weights, params, 0)
        full_s = time.perf_counter() - t
        best = set(out[0][np.argsort(out[2], kind="stable")[:TOP]].tolist())
        record = {"poses": len(poses), "full_s": full_s, "screens": []}
        for grid, stride, keep in SCREENS:
            p = replace(params, rerank_screen_grid=grid, rerank_screen_stride=stride)
            t = time.perf_counter()
            pick, moved, _ = full(terrain, poses, score, second, intrinsics, height, sky, weights, p, keep)
            s = time.perf_counter() - t
            same = all(np.array_equal(moved[pick == i][0], out[1][out[0] == i][0]) for i in best if i in set(pick))
            record["screens"].append({"kept_of_best": len(best & set(pick.tolist())) / len(best), "s": s, "same": same})
        records.append(record)
        return out

    pipeline.rerank_far_horizon = recorded
    params = LocalizeParams.for_photos()
    print(f"commit {git_commit()}; {len(chosen)} training-side CH1 photos, fov unknown, photo preset; per re-ranking "
          f"call: the share of the full re-ranking's best {TOP} by score that each screen keeps, seconds")
    print("screens (grid, column stride at 1,024 wide, kept by each ranking): " + ", ".join(map(str, SCREENS)))
    for it in chosen:
        records.clear()
        real_localize.run([it], ["unknown"], progress=False, params=params)
        for r in records:
            cells = "  ".join(f"{x['kept_of_best']:4.2f} {x['s']:4.1f}s{'' if x['same'] else '!'}" for x in r["screens"])
            print(f"{it.key:28s} poses {r['poses']:5d} full {r['full_s']:4.1f}s | {cells}", flush=True)
            all_records.append(r)
    print("\nsummary: mean share kept, photos-calls with every one kept, total seconds against the full re-ranking")
    full_total = sum(r["full_s"] for r in all_records)
    for n, screen in enumerate(SCREENS):
        kept = [r["screens"][n]["kept_of_best"] for r in all_records]
        total = sum(r["screens"][n]["s"] for r in all_records)
        print(f"  {str(screen):16s} mean {np.mean(kept):.3f}  all kept {sum(k == 1.0 for k in kept)}/{len(kept)}  "
              f"{total:6.1f} s vs {full_total:6.1f} s ({total / full_total:.2f})")


all_records: list[dict] = []

if __name__ == "__main__":
    main()
