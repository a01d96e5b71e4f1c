"""Reading and writing the small files of the CLI: skylines (.npy / JSON); native stderr capture."""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import tempfile

import numpy as np

from .errors import InputError


def save_skyline(path, skyline: np.ndarray) -> None:
    """Write a skyline as ``.npy`` (float64) or ``.json`` (a list, null for NaN)."""
    path = os.fspath(path)
    sky = np.asarray(skyline, dtype=np.float64)
    try:
        if path.lower().endswith(".json"):
            with open(path, "w") as fh:
                json.dump(skyline_to_list(sky), fh)
        else:
            with open(path, "wb") as fh:
                np.save(fh, sky)
    except OSError as exc:
        raise InputError(f"cannot write skyline {path}: {exc.strerror or exc}") from None


def load_skyline(path) -> np.ndarray:
    """Read a skyline written by :func:`save_skyline`, or the object ``skyrender skyline --json`` prints (its
    ``"skyline"``)."""
    path = os.fspath(path)
    try:
        if path.lower().endswith(".json"):
            with open(path) as fh:
                data = json.load(fh)
            if isinstance(data, dict) and "skyline" in data:
                data = data["skyline"]
            return np.array([np.nan if v is None else float(v) for v in data], dtype=np.float64)
        return np.asarray(np.load(path, allow_pickle=False), dtype=np.float64)
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"cannot read skyline {path}: {exc}") from None


def skyline_to_list(skyline) -> list:
    """JSON-ready list: floats, None for NaN."""
    return [None if not math.isfinite(v) else float(v) for v in np.asarray(skyline, dtype=np.float64)]


def camera_geojson(pose, fov_deg: float, dem, view_distance_m: float = 10_000.0, crs: str | None = None) -> dict:
    """GeoJSON FeatureCollection of a camera: its position (Point) and its view cone
    (Polygon: the camera and the arc of the horizontal field of view at
    ``view_distance_m``), in WGS 84 lon/lat when the DEM has a CRS, else in world x, y."""
    x, y, z, pan, tilt, swing = (float(v) for v in pose)
    angles = np.radians(pan + np.linspace(-fov_deg / 2, fov_deg / 2, 16))
    ring = np.column_stack([np.r_[x, x + view_distance_m * np.sin(angles), x],
                            np.r_[y, y + view_distance_m * np.cos(angles), y]])
    point = np.array([[x, y]])
    if dem.crs is not None:
        ring = np.column_stack(dem.to_lonlat(ring[:, 0], ring[:, 1]))
        point = np.column_stack(dem.to_lonlat(point[:, 0], point[:, 1]))
    props = {"x": x, "y": y, "z": z, "pan": pan, "tilt": tilt, "swing": swing, "fov": fov_deg, "crs": crs or dem.crs}
    return {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"kind": "camera", **props},
         "geometry": {"type": "Point", "coordinates": [float(point[0, 0]), float(point[0, 1])]}},
        {"type": "Feature", "properties": {"kind": "view cone", "distance_m": view_distance_m},
         "geometry": {"type": "Polygon", "coordinates": [ring.tolist()]}}]}


def write_json(path, obj: dict) -> None:
    """Write a JSON document; InputError when it cannot be written."""
    path = os.fspath(path)
    try:
        with open(path, "w") as fh:
            json.dump(obj, fh, indent=1)
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None


@contextlib.contextmanager
def captured_stderr():
    """Capture everything written to stderr inside the block, by Python and by native
    libraries (a decoder writing to file descriptor 2), into ``holder["text"]`` (set on
    exit): the command line prints one line per error, so a library's own complaint must
    not reach the terminal."""
    holder = {"text": ""}
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        try:
            os.dup2(tmp.fileno(), 2)
            yield holder
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            holder["text"] = tmp.read().decode("utf-8", "replace")
