"""Where the photo extractor's (``select``) time goes on a 1024-wide CH1 photo, 2 cores.

    python experiments/photos/speed-2026-12-06/threads.py

1. Each of its two extractors (hybrid, gmm) alone on one thread (both cores' worth of blocks forced onto one).
2. The two as ``select`` runs them, one thread each, the time of each thread, with OpenCV's own threads
   (the network) left at 2 and set to 1; the skylines compared with the default extraction's, to the bit.
"""
import time

import cv2
import numpy as np
from threadpoolctl import threadpool_limits

import skyrender.blocks as blocks
from skyrender.benchmarks.skyline_photos import method_params
from skyrender.blocks import concurrently
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import extract_skyline, load_photo
from skyrender.features import skyline as S
from skyrender.features.sky import pixel_features

it = next(i for i in items_on_side("validation") if i.key.startswith("ch1/"))
image = load_photo(it.image_path)
params = method_params("select")
reference = extract_skyline(image, params)
features = pixel_features(image)
edges = S._edge_strength(features, params.edge_percentile)
print(f"{it.key} {image.shape[1]} x {image.shape[0]}")

cpu_count = blocks.os.cpu_count
blocks.os.cpu_count = lambda: 1
with threadpool_limits(1):
    for method in ("hybrid", "gmm"):
        S._extract(image, features, edges, method, params)
        seconds = []
        for _ in range(3):
            t = time.perf_counter()
            S._extract(image, features, edges, method, params)
            seconds.append(time.perf_counter() - t)
        print(f"{method} alone on one thread: {np.round(seconds, 3).tolist()} s")
blocks.os.cpu_count = cpu_count


def timed(call):
    t = time.perf_counter()
    call()
    return time.perf_counter() - t


for threads in (cv2.getNumThreads(), 1):
    cv2.setNumThreads(threads)
    runs = []
    for _ in range(4):
        t = time.perf_counter()
        with threadpool_limits(1):
            hybrid_s, gmm_s = concurrently(lambda: timed(lambda: S._extract(image, features, edges, "hybrid", params)),
                                           lambda: timed(lambda: S._extract(image, features, edges, "gmm", params)))
        runs.append((time.perf_counter() - t, hybrid_s, gmm_s))
    out = extract_skyline(image, params)
    same = np.array_equal(out.skyline, reference.skyline, equal_nan=True) and np.array_equal(out.confidence,
                                                                                         reference.confidence)
    whole = []
    for _ in range(3):
        t = time.perf_counter()
        extract_skyline(image, params)
        whole.append(time.perf_counter() - t)
    print(f"OpenCV threads {threads}: the pair (wall, hybrid's thread, gmm's thread) {np.round(runs, 3).tolist()}; "
          f"select whole {np.round(whole, 3).tolist()} s; skylines as the default's to the bit: {same}")
