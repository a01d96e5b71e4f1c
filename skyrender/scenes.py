"""Scene definitions (``scenes/*.toml``): a DEM plus camera set-ups.

Format::

    dem = "builtin:jacksboro"      # or a path (relative to the scene file)
    crs = "EPSG:31254"             # optional, for DEM files without one
    [[views]]
    name = "..."
    lat = ... ; lon = ...          # or x = ... ; y = ... (world frame)
    height = 2.0                   # camera height above ground (m)
    pan = ... ; tilt = ... ; swing = ...   # degrees
    fov = 60.0 ; width = 640 ; height_px = 480
    [dataset.sampling]             # optional: how ``skyrender dataset`` draws views
    fov_deg = [25.0, 75.0]         # (fields of :class:`skyrender.datasets.synthetic.Sampling`)
    [dataset.realism]              # (fields of :class:`skyrender.datasets.synthetic.Realism`)
    skies = ["clear", "hazy"]

A scene needs ``[[views]]``, a ``[dataset]`` table, or both.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import tomllib

from .camera import Intrinsics, Pose
from .dem import DEM, load_dem
from .errors import InputError


@dataclass(frozen=True)
class View:
    name: str
    pose: Pose
    intrinsics: Intrinsics
    height_above_ground: float


@dataclass(frozen=True)
class Scene:
    dem: DEM
    views: tuple[View, ...]
    dem_ref: str = ""  # the scene file's ``dem`` as written
    dataset: dict | None = None  # the ``[dataset]`` table, if any


def load_scene(path) -> Scene:
    """Read a scene file; InputError on anything missing or malformed."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            spec = tomllib.load(fh)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"cannot read scene {path}: {exc}") from None
    dem_ref = spec.get("dem")
    if not dem_ref:
        raise InputError(f"{path}: no 'dem' given")
    if not str(dem_ref).startswith("builtin:") and not os.path.isabs(dem_ref):
        dem_ref = os.path.join(os.path.dirname(os.path.abspath(path)), dem_ref)
    dem = load_dem(dem_ref, crs=spec.get("crs"), cell_size=spec.get("cell_size"))
    views = []
    for i, v in enumerate(spec.get("views", [])):
        try:
            if "lat" in v:
                x, y = (float(a) for a in dem.from_lonlat(v["lon"], v["lat"]))
            else:
                x, y = float(v["x"]), float(v["y"])
            pose = dem.camera_pose(x, y, float(v["height"]), float(v["pan"]), float(v["tilt"]), float(v.get("swing", 0.0)))
            intr = Intrinsics.from_fov(float(v["fov"]), int(v["width"]), int(v["height_px"]))
        except KeyError as exc:
            raise InputError(f"{path}: view {i} lacks {exc.args[0]!r}") from None
        views.append(View(str(v.get("name", f"view{i}")), pose, intr, float(v["height"])))
    dataset = spec.get("dataset")
    if dataset is not None and not isinstance(dataset, dict):
        raise InputError(f"{path}: 'dataset' must be a table")
    if not views and dataset is None:
        raise InputError(f"{path}: no [[views]] and no [dataset] defined")
    return Scene(dem, tuple(views), str(spec["dem"]), dataset)
