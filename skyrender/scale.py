"""Scale-out on Dask: a client for a local cluster or an existing scheduler.

``skyrender dataset`` and ``skyrender experiment`` send one view per task; each
worker builds the terrain (and model) once and keeps it for its later tasks. A
worker is a single-threaded process: Dr.Jit and numpy already use the cores a
process is given, and processes keep Mitsuba's global state apart.
"""

from __future__ import annotations

from contextlib import contextmanager

from .errors import InputError


@contextmanager
def dask_client(workers: int = 0, scheduler: str | None = None):
    """A ``distributed.Client``: connected to ``scheduler`` (an address such as
    ``tcp://host:8786``) when given, else on a ``LocalCluster`` of ``workers`` processes
    (one thread each, no dashboard). Closed (and the local cluster shut down) on exit."""
    import logging

    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)  # its INFO lines are not the user's business
    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise InputError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        try:
            yield client
        finally:
            client.close()
        return
    if workers < 1:
        raise InputError(f"--workers must be >= 1 for a local Dask cluster, got {workers}")
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        yield client
