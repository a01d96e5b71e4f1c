"""Row blocks of a large array worked through on all cores.

The hot paths (the far-horizon costs, the skyline alignment, the colour mixtures' densities) are row-wise numpy
passes over arrays of millions of elements: one pass at a time streams them through memory on
one core. Cut into blocks of rows, each block's temporaries stay in the cache and the blocks
run on threads (numpy releases the GIL inside its loops), with the whole array's values.

Work already running on one of these threads does its own blocks and calls one after the other: the cores
are taken by its siblings, and threads within threads only fight over them and the GIL (the photo
extractor's two skylines, each with its mixtures' fits and densities inside, 0.73-1.0 s -> 0.69 s on 2 cores,
the same skylines to the bit).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, TypeVar

T = TypeVar("T")

_worker = threading.local()  # .busy: this thread is one of in_blocks' or concurrently's workers


def _parallel(tasks: int) -> int:
    """Threads for ``tasks`` independent pieces: 1 (run in this thread) for one piece, one core,
    or inside another of this module's workers; else one per piece, at most one per core."""
    if tasks <= 1 or getattr(_worker, "busy", False):
        return 1
    return min(tasks, os.cpu_count() or 1)


def _as_worker(call: Callable[[], T]) -> T:
    _worker.busy = True
    try:
        return call()
    finally:
        _worker.busy = False


def in_blocks(n_rows: int, rows_per_block: int, work: Callable[[int, int], None]) -> None:
    """Call ``work(lo, hi)`` for consecutive blocks of ``rows_per_block`` rows covering
    ``n_rows``, on a thread per core when there is more than one block and one core (and
    this is not already one of this module's worker threads)."""
    blocks = [(lo, min(lo + rows_per_block, n_rows)) for lo in range(0, n_rows, rows_per_block)]
    threads = _parallel(len(blocks))
    if threads > 1:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            list(pool.map(lambda b: _as_worker(lambda: work(*b)), blocks))
    else:
        for lo, hi in blocks:
            work(lo, hi)


def concurrently(*calls: Callable[[], T]) -> list[T]:
    """The results of ``calls`` (functions of no arguments), in order: each on its own thread
    when there is more than one call and one core (and this is not already one of this
    module's worker threads), else one after the other. For independent pieces of numpy
    work too small to cut into blocks (two mixtures' EM fits)."""
    threads = _parallel(len(calls))
    if threads > 1:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            return [f.result() for f in [pool.submit(_as_worker, c) for c in calls]]
    return [c() for c in calls]
