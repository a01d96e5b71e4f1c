"""Row blocks of a large array worked through on all cores.

The hot paths (the far-horizon costs, the skyline alignment, the colour mixtures' densities) are row-wise numpy
passes over arrays of millions of elements: one pass at a time streams them through memory on
one core. Cut into blocks of rows, each block's temporaries stay in the cache and the blocks
run on threads (numpy releases the GIL inside its loops), with the whole array's values.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, TypeVar

T = TypeVar("T")


def in_blocks(n_rows: int, rows_per_block: int, work: Callable[[int, int], None]) -> None:
    """Call ``work(lo, hi)`` for consecutive blocks of ``rows_per_block`` rows covering
    ``n_rows``, on a thread per core when there is more than one block and one core."""
    blocks = [(lo, min(lo + rows_per_block, n_rows)) for lo in range(0, n_rows, rows_per_block)]
    cores = os.cpu_count() or 1
    if len(blocks) > 1 and cores > 1:
        with ThreadPoolExecutor(max_workers=min(cores, len(blocks))) as pool:
            list(pool.map(lambda b: work(*b), blocks))
    else:
        for lo, hi in blocks:
            work(lo, hi)


def concurrently(*calls: Callable[[], T]) -> list[T]:
    """The results of ``calls`` (functions of no arguments), in order: each on its own thread
    when there is more than one call and one core, else one after the other. For independent
    pieces of numpy work too small to cut into blocks (two mixtures' EM fits)."""
    if len(calls) > 1 and (os.cpu_count() or 1) > 1:
        with ThreadPoolExecutor(max_workers=min(len(calls), os.cpu_count() or 1)) as pool:
            return [f.result() for f in [pool.submit(c) for c in calls]]
    return [c() for c in calls]
