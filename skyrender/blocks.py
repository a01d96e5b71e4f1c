"""Row blocks of a large array worked through on all cores.

The hot paths (the far-horizon costs, the skyline alignment, the colour mixtures' densities) are row-wise numpy
passes over arrays of millions of elements: one pass at a time streams them through memory on
one core. Cut into blocks of rows, each block's temporaries stay in the cache and the blocks
run on threads (numpy releases the GIL inside its loops), with the whole array's values.

Work already running on one of these threads does its own blocks and calls one after the other while its siblings
hold the other cores: threads within threads would only fight over them and the GIL (the photo extractor's two
skylines, each with its mixtures' fits and densities inside, 0.73-1.0 s -> 0.69 s on 2 cores, the same skylines to
the bit). A core a sibling has finished with is taken again: nested work then runs on it too (the photo extractor's
``gmm`` line, the longer of its two, spreads its last rounds over both cores once the ``hybrid`` line is done). Which
thread works a block never changes its values.
"""

from __future__ import annotations

import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, TypeVar

T = TypeVar("T")

_worker = threading.local()  # .busy: this thread is one of in_blocks' or concurrently's workers
_lock = threading.Lock()
_working = 0  # this module's worker threads now working (not waiting on threads of their own)


def _parallel(tasks: int) -> int:
    """Threads for ``tasks`` independent pieces: 1 (run in this thread) for one piece or one core; else one per
    piece, at most one per core; inside one of this module's workers, at most its own core and those no other
    worker is working on."""
    cores = os.cpu_count() or 1
    if tasks <= 1 or cores <= 1:
        return 1
    if not getattr(_worker, "busy", False):
        return min(tasks, cores)
    with _lock:
        free = cores - _working
    return max(1, min(tasks, free + 1))


def _count_working(change: int) -> None:
    global _working
    with _lock:
        _working += change


def _as_worker(call: Callable[[], T]) -> T:
    _worker.busy = True
    _count_working(+1)
    try:
        return call()
    finally:
        _count_working(-1)
        _worker.busy = False


def _on_threads(threads: int, run: Callable[[ThreadPoolExecutor], T]) -> T:
    """``run(pool)`` with a pool of ``threads`` threads; a worker calling this counts as not working while it
    waits on them (its core is theirs)."""
    waiting = getattr(_worker, "busy", False)
    if waiting:
        _count_working(-1)
    try:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            return run(pool)
    finally:
        if waiting:
            _count_working(+1)


def in_blocks(n_rows: int, rows_per_block: int, work: Callable[[int, int], None]) -> None:
    """Call ``work(lo, hi)`` for consecutive blocks of ``rows_per_block`` rows covering
    ``n_rows``, on a thread per core when there is more than one block and one core (in one of
    this module's workers: on the cores its siblings are not working on, and its own), else in turn."""
    blocks = [(lo, min(lo + rows_per_block, n_rows)) for lo in range(0, n_rows, rows_per_block)]
    threads = _parallel(len(blocks))
    if threads > 1:
        _on_threads(threads, lambda pool: list(pool.map(lambda b: _as_worker(lambda: work(*b)), blocks)))
    else:
        for lo, hi in blocks:
            work(lo, hi)


def concurrently(*calls: Callable[[], T]) -> list[T]:
    """The results of ``calls`` (functions of no arguments), in order: each on its own thread
    when there is more than one call and one core (in one of this module's workers: on the cores
    its siblings are not working on, and its own), else one after the other. For
    independent pieces of numpy work too small to cut into blocks (two mixtures' EM fits)."""
    threads = _parallel(len(calls))
    if threads > 1:
        return _on_threads(threads, lambda pool: [f.result() for f in [pool.submit(_as_worker, c) for c in calls]])
    return [c() for c in calls]


class Once:
    """A value made by ``make()`` (no arguments) on its first request, by whichever thread asks first; a thread
    asking while it is being made waits for it. For work two concurrent lines both need, the one that needs it first
    paying for it (the photo extractor's colour edges, texture cost and mixture inputs:
    :class:`skyrender.features.skyline.PhotoWork`)."""

    def __init__(self, make: Callable[[], T]):
        self._make = make
        self._lock = threading.Lock()
        self._made = False
        self._value = None

    def __call__(self) -> T:
        with self._lock:
            if not self._made:
                self._value, self._made = self._make(), True
                self._make = None  # what it closed over is no longer needed
        return self._value


def made(value):
    """``value()`` for a :class:`Once`, else ``value`` itself."""
    return value() if isinstance(value, Once) else value


_controller: tuple[int, object] | None = None  # (len(sys.modules) when made, threadpoolctl's ThreadpoolController)


def one_thread(user_api: str | None = None):
    """A context in which the native thread pools threadpoolctl knows (``user_api="blas"``: BLAS only) run one
    thread each, as ``threadpoolctl.threadpool_limits(1, user_api)`` does. That looks up the loaded libraries on
    every call (2 ms; ~20 calls a photo in the skyline extractor); the lookup here is kept and made again only
    when more modules have been imported since (one might have loaded another pool)."""
    global _controller
    from threadpoolctl import ThreadpoolController

    if _controller is None or _controller[0] != len(sys.modules):
        _controller = (len(sys.modules), ThreadpoolController())
    return _controller[1].limit(limits=1, user_api=user_api)
