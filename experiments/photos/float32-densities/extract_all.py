"""Extract every real photo of the split with the photo extractor (``select``) and keep its skyline, column confidence
and seconds: one run of the code on ``PYTHONPATH`` (a worktree of the commit before, or this one), for ``compare.py``.

    PYTHONPATH=<checkout> python experiments/photos/float32-densities/extract_all.py --out RUN.npz
        [--sides train dev validation heldout] [--only-ch1] [--repeats N]

With ``--repeats`` each photo is extracted N times in a row and its least seconds kept (the skyline of the first).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.features import SkylineParams, extract_skyline, load_photo


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--sides", nargs="+", default=["train", "dev", "validation", "heldout"])
    ap.add_argument("--only-ch1", action="store_true")
    ap.add_argument("--repeats", type=int, default=1)
    args = ap.parse_args(argv)
    params = SkylineParams(method="select")
    keys, widths, seconds, arrays = [], [], [], {}
    extract_skyline(load_photo(items_on_side("heldout")[0].image_path), params)  # warm-up: numba, the network
    for side in args.sides:
        for item in items_on_side(side):
            if args.only_ch1 and not item.key.startswith("ch1/"):
                continue
            image = load_photo(item.image_path)
            times, results = [], []
            for _ in range(args.repeats):
                t = time.perf_counter()
                results.append(extract_skyline(image, params))
                times.append(time.perf_counter() - t)
            result = results[0]
            seconds.append(min(times))
            keys.append(f"{side}:{item.key}")
            widths.append(image.shape[1])
            arrays[f"skyline:{len(keys) - 1}"] = result.skyline
            arrays[f"confidence:{len(keys) - 1}"] = result.confidence
    np.savez_compressed(args.out, keys=np.array(keys), widths=np.array(widths), seconds=np.array(seconds),
                        commit=np.array(git_commit()), **arrays)
    print(f"{len(keys)} photos, median {np.median(seconds):.3f} s, to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
