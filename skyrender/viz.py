"""Pictures for people: skylines and labels drawn over photographs."""

from __future__ import annotations

import numpy as np


def draw_skyline(image: np.ndarray, skyline: np.ndarray, colour=(255, 0, 0), thickness: int = 2) -> np.ndarray:
    """Copy of an (H, W, 3) RGB uint8 image with the skyline (v per column, NaN = none)
    drawn as a polyline; runs of NaN break the line."""
    import cv2

    out = np.ascontiguousarray(image.copy())
    u = np.arange(len(skyline)) + 0.5
    ok = np.isfinite(skyline)
    shift = 4  # OpenCV fixed-point sub-pixel drawing: 1/16 px
    for run in np.split(np.arange(len(skyline)), np.flatnonzero(np.diff(ok.astype(int))) + 1):
        run = run[ok[run]]
        if len(run) == 0:
            continue
        pts = np.round(np.stack([u[run], skyline[run]], 1) * (1 << shift)).astype(np.int32)
        cv2.polylines(out, [pts], False, colour, thickness, cv2.LINE_AA, shift)
    return out


def write_image(path, image: np.ndarray) -> None:
    """Write an RGB (or gray) uint8 image; InputError when the file cannot be written."""
    import os

    import cv2

    from .errors import InputError

    path = os.fspath(path)
    bgr = image[..., ::-1] if image.ndim == 3 else image
    try:
        ok = cv2.imwrite(path, np.ascontiguousarray(bgr))
    except cv2.error as exc:
        raise InputError(f"cannot write image {path}: {str(exc).strip().splitlines()[-1]}") from None
    if not ok:
        raise InputError(f"cannot write image {path} (unknown extension or unwritable location)")
