"""The render preset's extractor (``gmm``) on ``make bench-localize``'s rendered views (the synthetic 600² scene, seed 1):
skylines and confidences kept, for ``compare.py``, as ``extract_all.py`` keeps the photos'.

    PYTHONPATH=<checkout> python experiments/photos/float32-densities/renders_gmm.py --views 30 --out RUN.npz
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from skyrender.benchmarks.views import bench_localize_views
from skyrender.dem.synthetic import fractal_terrain
from skyrender.evaluate import git_commit
from skyrender.features import SkylineParams, extract_skyline
from skyrender.model import build_model
from skyrender.render import Terrain


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--views", type=int, default=30)
    args = ap.parse_args(argv)
    dem = fractal_terrain()
    terrain = Terrain(dem)
    _, _, photos = bench_localize_views(terrain, build_model(dem, terrain=terrain), args.views, 1)
    params = SkylineParams()
    extract_skyline(photos[0], params)  # warm-up
    keys, seconds, arrays = [], [], {}
    for k, photo in enumerate(photos):
        t = time.perf_counter()
        result = extract_skyline(photo, params)
        seconds.append(time.perf_counter() - t)
        keys.append(f"render:{k}")
        arrays[f"skyline:{k}"] = result.skyline
        arrays[f"confidence:{k}"] = result.confidence
    np.savez_compressed(args.out, keys=np.array(keys), widths=np.array([p.shape[1] for p in photos]),
                        seconds=np.array(seconds), commit=np.array(git_commit()), **arrays)
    print(f"{len(keys)} renders, median {np.median(seconds):.3f} s, to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
