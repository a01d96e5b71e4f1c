"""Where the photo extractor's time goes: ``select`` on the first 6 CH1 dev photos (1024 x 767), everything on
one thread (``blocks._parallel`` forced to 1, BLAS and OpenMP held to one thread), under cProfile.

``python experiments/photos/speed-2026-12-05/where_time_goes.py > experiments/photos/speed-2026-12-05/where_time_goes.txt``

Prints the seconds of work per photo (cProfile's own overhead included) and the functions by cumulative time.
"""

from __future__ import annotations

import cProfile
import pstats
import time

from threadpoolctl import threadpool_limits

import skyrender.blocks as blocks
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.features import SkylineParams, extract_skyline, load_photo


def main() -> None:
    blocks._parallel = lambda tasks: 1  # one thread: the work itself, not how it is shared
    items = [it for it in items_on_side("dev") if it.key.startswith("ch1/")][:6]
    images = [load_photo(it.image_path) for it in items]
    extract_skyline(images[0], SkylineParams(method="select"))  # imports and the network's load
    with threadpool_limits(1):
        start = time.perf_counter()
        profile = cProfile.Profile()
        profile.enable()
        for image in images:
            extract_skyline(image, SkylineParams(method="select"))
        profile.disable()
        seconds = (time.perf_counter() - start) / len(images)
    print(f"commit {git_commit()}; {len(images)} photos {images[0].shape[1]} x {images[0].shape[0]}; "
          f"select on one thread: {seconds:.2f} s of work a photo (profiled)")
    pstats.Stats(profile).sort_stats("cumulative").print_stats(30)


if __name__ == "__main__":
    main()
