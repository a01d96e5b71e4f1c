"""The model databases on disk: a versioned, self-contained ``MODEL_DIR``.

``MODEL_DIR/model.json`` — format name and version, the DEM's fingerprint,
grid, CRS and name, the build parameters, counts and build time.
``MODEL_DIR/arrays.npz`` — the DEM elevations (so a model localizes on its
own), the Model Feature Point Database (id, x, y, z, lon, lat, row, col,
prominence, major), the pivots, their k nearest feature points, and the
co-visibility counts (every feature pair), and the Model Horizon Database
(grid centres and their far-horizon elevation angles, float16 degrees).

A model whose format version, DEM fingerprint or parameters do not match
what the caller expects is refused with a message saying so.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np
from affine import Affine

from ..config import params_from_dict, params_to_dict
from ..dem import DEM
from ..errors import InputError
from .covisibility import Covisibility, CovisibilityParams
from .horizons import HorizonParams, Horizons
from .peaks import PeakParams, PeakTable

FORMAT = "skyrender-model"
FORMAT_VERSION = 3  # 2: co-visibility counts for every feature pair, not only pivots'; 3: far horizons


@dataclass(frozen=True)
class ModelParams:
    peaks: PeakParams = field(default_factory=PeakParams)
    k: int = 15
    covisibility: CovisibilityParams = field(default_factory=CovisibilityParams)
    horizons: HorizonParams = field(default_factory=HorizonParams)
    # co-visibility and far horizons are rendered on the DEM block-averaged to about this cell
    # size (m) where it is finer (a 1-arc-second tile's 26 m cells: 2 x 2 blocks); peaks, and
    # every render of the localizer, use the DEM itself (0: always the DEM itself)
    render_cell_m: float = 40.0

    def render_factor(self, cell_m: float) -> int:
        """The block factor of the model's renders for a DEM of ``cell_m`` (m) cells."""
        return max(1, int(round(self.render_cell_m / cell_m))) if self.render_cell_m > 0 else 1

    def to_dict(self) -> dict:
        return params_to_dict(self)

    @classmethod
    def for_photos(cls) -> "ModelParams":
        """A model for real photographs: far horizons from 300 m out (their skylines are
        often ridges 1-3 km away) on a 500 m grid, up to 60,000 centres (a 1.2 x 1.4 deg
        SRTM window); on the CH1 training photos this ranked a candidate within 1 km of
        the truth among the best verified in 6 of 12, where 1 km out and 1 km apart found
        none but one (``experiments/ch1/README.md``)."""
        return cls(horizons=HorizonParams(spacing=500.0, near_m=300.0, max_centres=60_000))

    @classmethod
    def from_dict(cls, d: dict, base: "ModelParams | None" = None) -> "ModelParams":
        return params_from_dict(cls, d, base)


@dataclass(frozen=True, eq=False)
class Model:
    """Peak databases, neighbour sets and co-visibility statistics of one DEM."""

    dem: DEM
    params: ModelParams
    features: PeakTable
    neighbours: np.ndarray  # (P, k) feature rows, -1 = none
    covisibility: Covisibility
    horizons: Horizons
    build_seconds: float = 0.0
    stage_seconds: dict = field(default_factory=dict)  # of the build (not saved): peaks, covisibility, horizons...

    @property
    def pivots(self) -> np.ndarray:
        """Feature-table rows of the major peaks (pivots), in table order."""
        return np.flatnonzero(self.features.major)

    @property
    def p_pivot(self) -> np.ndarray:
        """(P,) P(pivot)."""
        return self.covisibility.p_pivot(self.pivots)

    @property
    def p_neighbour(self) -> np.ndarray:
        """(P, k) P(neighbour j | pivot i) for each pivot's k nearest; 0 for missing ones."""
        cond = self.covisibility.p_given_pivot(self.pivots)
        nb = self.neighbours
        return np.where(nb >= 0, np.take_along_axis(cond, np.maximum(nb, 0), axis=1), 0.0)

    def features_for_prior(self, ids=None, x: float | None = None, y: float | None = None,
                           radius: float | None = None) -> np.ndarray:
        """(F,) bool: the feature points a prior "mountain X is visible" names — by
        feature id, or every feature within ``radius`` metres of (x, y). All when no prior."""
        f = self.features
        if ids is None and x is None:
            return np.ones(len(f), dtype=bool)
        allowed = np.zeros(len(f), dtype=bool)
        if ids is not None:
            ids = np.asarray(list(ids), dtype=np.int64)
            unknown = np.setdiff1d(ids, f.id)
            if len(unknown):
                raise InputError(f"unknown peak id(s) {', '.join(map(str, unknown[:5]))}")
            allowed |= np.isin(f.id, ids)
        if x is not None:
            if y is None or radius is None or not radius > 0:
                raise InputError("a position prior needs x, y and a positive radius")
            allowed |= np.hypot(f.x - x, f.y - y) <= radius
        return allowed

    def summary(self) -> str:
        rows, cols = self.dem.shape
        return (f"model of {self.dem.name}: {len(self.features)} feature points ({int(self.features.major.sum())} major), "
                f"k = {self.params.k}, {self.covisibility.n_viewpoints} viewpoints; grid {cols} x {rows} cells of "
                f"{self.dem.cell_size[0]:g} m ({self.dem.crs or 'local frame'}); {len(self.horizons)} far horizons; "
                f"built in {self.build_seconds:.1f} s")


def save_model(model: Model, out_dir) -> None:
    """Write ``model`` to ``out_dir`` (created if needed); InputError if it cannot be."""
    out_dir = os.fspath(out_dir)
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create model directory {out_dir}: {exc.strerror or exc}") from None
    if not os.access(out_dir, os.W_OK):
        raise InputError(f"model directory {out_dir} is not writable")
    f = model.features
    lon = lat = np.full(len(f), np.nan)
    if model.dem.crs is not None and len(f):
        lon, lat = model.dem.to_lonlat(f.x, f.y)
    meta = {
        "format": FORMAT, "format_version": FORMAT_VERSION,
        "dem": {"name": model.dem.name, "fingerprint": model.dem.fingerprint(), "crs": model.dem.crs,
                "transform": list(tuple(model.dem.transform)[:6]), "shape": list(model.dem.shape),
                "voids_filled": model.dem.repair.voids_filled, "spikes_repaired": model.dem.repair.spikes_repaired},
        "params": model.params.to_dict(),
        "counts": {"features": len(f), "major": int(f.major.sum()), "viewpoints": model.covisibility.n_viewpoints},
        "build_seconds": model.build_seconds,
    }
    arrays = {
        "elevation": model.dem.elevation, "id": f.id, "x": f.x, "y": f.y, "z": f.z, "lon": np.asarray(lon),
        "lat": np.asarray(lat), "row": f.row, "col": f.col, "prominence": f.prominence, "major": f.major,
        "neighbours": model.neighbours, "together": model.covisibility.together.astype(np.int32),
        "horizon_centres": model.horizons.centres, "horizon_elevation": model.horizons.elevation.astype(np.float16),
    }
    try:
        tmp = os.path.join(out_dir, "arrays.tmp.npz")
        np.savez(tmp, **arrays)
        os.replace(tmp, os.path.join(out_dir, "arrays.npz"))
        with open(os.path.join(out_dir, "model.json"), "w") as fh:
            json.dump(meta, fh, indent=2)
    except OSError as exc:
        raise InputError(f"cannot write the model to {out_dir}: {exc.strerror or exc}") from None


def load_model(model_dir, dem: DEM | None = None, params: ModelParams | None = None) -> Model:
    """Read a model; refuse one of another format version, another DEM or other parameters."""
    model_dir = os.fspath(model_dir)
    meta_path = os.path.join(model_dir, "model.json")
    try:
        with open(meta_path) as fh:
            meta = json.load(fh)
    except FileNotFoundError:
        raise InputError(f"{model_dir} is not a skyrender model (no model.json); build one with 'skyrender model'") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read model {meta_path}: {exc}") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError(f"{model_dir} is not a skyrender model")
    if meta.get("format_version") != FORMAT_VERSION:
        raise InputError(f"model {model_dir} has format version {meta.get('format_version')}, this skyrender reads "
                         f"{FORMAT_VERSION}: rebuild it with 'skyrender model'")
    try:
        stored = ModelParams.from_dict(meta["params"])
        meta["dem"]["fingerprint"], meta["dem"]["name"], meta["counts"]["viewpoints"]
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"model {model_dir} is corrupt: model.json lacks or garbles {exc}") from None
    if params is not None and stored != params:
        raise InputError(f"model {model_dir} was built with other parameters: rebuild it with 'skyrender model'")
    if dem is not None and dem.fingerprint() != meta["dem"]["fingerprint"]:
        raise InputError(f"model {model_dir} was built for DEM {meta['dem']['name']!r} "
                         f"(fingerprint {meta['dem']['fingerprint']}), not for {dem.name!r} ({dem.fingerprint()}): "
                         f"rebuild it with 'skyrender model'")
    import zipfile

    try:
        a = np.load(os.path.join(model_dir, "arrays.npz"), allow_pickle=False)
        arrays = {k: a[k] for k in a.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"cannot read model arrays in {model_dir}: {reason}") from None
    required = ("id", "x", "y", "z", "row", "col", "prominence", "major", "together", "horizon_centres",
                "horizon_elevation", "neighbours") + (() if dem is not None else ("elevation",))
    missing = [k for k in required if k not in arrays]
    if missing:
        raise InputError(f"model {model_dir} is corrupt: arrays.npz lacks {', '.join(missing)}")
    if dem is None:
        d = meta["dem"]
        dem = DEM(arrays["elevation"], Affine(*d["transform"]), d["crs"], d["name"])
        if dem.fingerprint() != d["fingerprint"]:
            raise InputError(f"model {model_dir} is corrupt: its DEM does not match its fingerprint")
    features = PeakTable(arrays["id"], arrays["x"], arrays["y"], arrays["z"], arrays["row"], arrays["col"],
                         arrays["prominence"], arrays["major"].astype(bool))
    covis = Covisibility(int(meta["counts"]["viewpoints"]), arrays["together"])
    horizons = Horizons(arrays["horizon_centres"], arrays["horizon_elevation"].astype(np.float32),
                        stored.horizons.bin_deg)
    return Model(dem, stored, features, arrays["neighbours"], covis, horizons, float(meta.get("build_seconds", 0.0)))
