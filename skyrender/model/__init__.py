"""Stage 1 — the model side (offline): peaks, neighbour sets, co-visibility, far horizons.

Entry point: :func:`build_model` (DEM -> :class:`Model`); :func:`save_model`
and :func:`load_model` keep it in a versioned ``MODEL_DIR``.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from pathlib import Path

from ..dem import DEM
from ..errors import InputError
from .covisibility import Covisibility, CovisibilityParams, learn_covisibility
from .database import Model, ModelParams, load_model, save_model
from .horizons import HorizonParams, Horizons, build_horizons
from .neighbours import k_nearest_features
from .peaks import PeakParams, PeakTable, find_peaks

__all__ = ["build_model", "cached_model", "model_cache_key", "Model", "ModelParams", "PeakParams", "CovisibilityParams",
           "CACHE_GENERATION", "load_model", "save_model",
           "find_peaks", "k_nearest_features", "learn_covisibility", "PeakTable", "Covisibility", "HorizonParams",
           "Horizons", "build_horizons"]


def build_model(dem: DEM, params: ModelParams = ModelParams(), *, terrain=None, progress: bool = False) -> Model:
    """Build the model databases of a DEM: peaks -> k-nearest sets -> co-visibility -> far horizons.

    ``terrain`` (a :class:`~skyrender.render.Terrain` of the same DEM) may be passed to
    reuse its Mitsuba scene. InputError when the DEM has no peaks at all.
    """
    from ..render import Terrain

    if params.k < 2:
        raise InputError(f"k must be at least 2 (a pivot and two neighbours make a triple), got {params.k}")
    t0 = time.perf_counter()
    seconds = {}
    features = find_peaks(dem, params.peaks)
    if dem.invented is not None and len(features):  # no peak of terrain the DEM's loading made up
        features = features.subset(~dem.is_invented(features.xyz[:, 0], features.xyz[:, 1]))
    if len(features) == 0 or not features.major.any():
        raise InputError(f"{dem.name}: no peaks found (a flat or featureless DEM, or radii larger than the DEM)")
    pivots = features.subset(features.major)
    neighbours = k_nearest_features(pivots.xyz[:, :2], features.xyz[:, :2], pivots.id, params.k)
    seconds["peaks"] = time.perf_counter() - t0
    tick = time.perf_counter()
    factor = params.render_factor(min(dem.cell_size))
    if factor > 1:  # a fine DEM: the model's statistics need no 26 m mesh (build time and memory)
        keep = {} if terrain is None else {"curvature": terrain.curvature, "variant": terrain.variant}
        terrain = Terrain(dem.coarsened(factor), **keep)
    terrain = terrain or Terrain(dem)
    seconds["terrain"] = time.perf_counter() - tick
    tick = time.perf_counter()
    covis = learn_covisibility(terrain, features.xyz, params.covisibility, progress=progress)
    seconds["covisibility"] = time.perf_counter() - tick
    tick = time.perf_counter()
    # the horizons' centres stand on the DEM itself: the localizer places its cameras there
    horizons = build_horizons(terrain, params.horizons, grid_dem=dem, progress=progress)
    seconds["horizons"] = time.perf_counter() - tick
    return Model(dem, params, features, neighbours, covis, horizons, time.perf_counter() - t0,
                 {k: round(v, 2) for k, v in seconds.items()})


def model_cache_dir() -> Path:
    """Where built models are cached: ``$SKYRENDER_CACHE`` or ``~/.cache/skyrender``."""
    return Path(os.environ.get("SKYRENDER_CACHE", Path.home() / ".cache" / "skyrender"))


def model_cache_key(dem: DEM, params: ModelParams = ModelParams()) -> str:
    """The cache directory name of a model: the DEM's fingerprint, plus a hash of the
    parameters where they are not the defaults."""
    key = dem.fingerprint()
    if params != ModelParams():
        d = params.to_dict()
        if d["render_cell_m"] == ModelParams.render_cell_m:  # keys written before the field existed stay valid
            del d["render_cell_m"]
        key += "-" + hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:10]
    return key


#: Bumped when a change of the code (not of the parameters) changes what a model holds, so that
#: models cached before it are rebuilt: 2 = far horizons rendered with the per-shape frozen
#: kernel (2d87ab4, 2026-12-02; before it, a model built in a process that had localized could
#: hold wrongly replayed horizons); 3 = one bisected column per horizon bin (2026-12-04); 4 = no peaks, viewpoints
#: or far-horizon centres on terrain the DEM's loading invented (``DEM.invented``, 2026-12-05).
CACHE_GENERATION = 4


def cached_model(dem: DEM, params: ModelParams = ModelParams(), *, terrain=None, progress: bool = False) -> Model:
    """The model of ``dem`` built with ``params`` from the cache (keyed by the DEM's
    fingerprint and the parameters, under ``g<CACHE_GENERATION>``), built and cached on first
    use; an unwritable cache only costs the rebuild next time. ``progress``: a line and
    progress bars on stderr while it is built."""
    cache = model_cache_dir() / f"g{CACHE_GENERATION}" / model_cache_key(dem, params)
    try:
        return load_model(cache, dem=dem, params=params)
    except InputError:
        pass
    if progress:
        rows, cols = dem.shape
        print(f"skyrender: building the model of {dem.name} ({rows} x {cols} cells; first use, cached in {cache})",
              file=sys.stderr, flush=True)
    built = build_model(dem, params, terrain=terrain, progress=progress)
    try:
        save_model(built, cache)
    except InputError:
        pass
    return built
