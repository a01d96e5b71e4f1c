"""Reading and writing the small files of the CLI: skylines (.npy / JSON)."""

from __future__ import annotations

import json
import math
import os

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
    """Read a skyline written by :func:`save_skyline`."""
    path = os.fspath(path)
    try:
        if path.lower().endswith(".json"):
            with open(path) as fh:
                data = json.load(fh)
            return np.array([np.nan if v is None else float(v) for v in data], dtype=np.float64)
        return np.asarray(np.load(path, allow_pickle=False), dtype=np.float64)
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"cannot read skyline {path}: {exc}") from None


def skyline_to_list(skyline) -> list:
    """JSON-ready list: floats, None for NaN."""
    return [None if not math.isfinite(v) else float(v) for v in np.asarray(skyline, dtype=np.float64)]
