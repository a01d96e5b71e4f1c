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


class SplitSolver:
    """:func:`skyrender.localizer.pose_solver.solve_poses` with each batch of hypotheses
    split into ``parts`` contiguous pieces solved on the workers of a Dask ``client``
    (one localization's hypothesis search spread over a cluster). The DEM is sent to
    every worker once. Hypotheses are independent rows, so the poses and residuals are
    the local solver's, in the same order (a test checks it)."""

    def __init__(self, client, dem, parts: int | None = None):
        self.client = client
        self.dem = dem
        self.parts = parts or max(1, len(client.scheduler_info().get("workers", {})))
        self._dem_future = client.scatter(dem, broadcast=True)

    def __call__(self, dem, image_uv, world, height, f_px, cx, cy, curvature=True, gn_iterations=5):
        import numpy as np

        from .localizer.pose_solver import solve_poses

        if dem is not self.dem:
            raise ValueError("SplitSolver was set up for another DEM")
        bounds = np.linspace(0, len(world), self.parts + 1).astype(int)
        futures = [self.client.submit(solve_poses, self._dem_future, image_uv[a:b], world[a:b], height,
                                      f_px if np.ndim(f_px) == 0 else f_px[a:b], cx, cy, curvature, gn_iterations,
                                      pure=False)
                   for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
        if not futures:
            return solve_poses(dem, image_uv, world, height, f_px, cx, cy, curvature, gn_iterations)
        parts = self.client.gather(futures)
        return np.concatenate([p for p, _ in parts]), np.concatenate([r for _, r in parts])
