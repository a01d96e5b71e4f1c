"""Reading the photographs users have: any size, gray/RGB/RGBA, 8 or 16 bit."""

from __future__ import annotations

import os

import numpy as np

from ..errors import InputError

MIN_SIDE = 8  # smaller images hold no skyline worth the name


def load_photo(path) -> np.ndarray:
    """Read an image file as an (H, W, 3) RGB uint8 array; InputError otherwise.

    Gray images are replicated to three channels, alpha is composited over white
    (transparent areas carry no scene), 16-bit images are scaled to 8 bit.
    """
    import cv2

    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError(f"image file not found: {path}")
    if os.path.isdir(path):
        raise InputError(f"image path is a directory: {path}")
    data = np.fromfile(path, dtype=np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
    if image is None:
        raise InputError(f"{path}: not an image that can be read")
    return as_rgb8(image, name=path, bgr=True)


def as_rgb8(image: np.ndarray, name: str = "image", bgr: bool = False) -> np.ndarray:
    """Normalise an array image to (H, W, 3) RGB uint8 (``bgr``: channel order as OpenCV reads)."""
    image = np.asarray(image)
    if image.ndim == 2:
        image = image[..., None]
    if image.ndim != 3 or image.shape[2] not in (1, 3, 4):
        raise InputError(f"{name}: unsupported image shape {image.shape}")
    if min(image.shape[:2]) < MIN_SIDE:
        raise InputError(f"{name}: image is {image.shape[1]} x {image.shape[0]} pixels; at least "
                         f"{MIN_SIDE} x {MIN_SIDE} are needed")
    if image.dtype == np.uint16:
        image = (image.astype(np.float64) / 257.0).round()
    elif np.issubdtype(image.dtype, np.floating):
        image = np.clip(image * (255.0 if np.nanmax(image) <= 1.0 else 1.0), 0, 255)
    image = np.nan_to_num(image).astype(np.float64)
    if image.shape[2] == 1:
        image = np.repeat(image, 3, axis=2)
    elif image.shape[2] == 4:
        alpha = image[..., 3:4] / 255.0
        image = image[..., :3] * alpha + 255.0 * (1 - alpha)
    if bgr:
        image = image[..., ::-1]
    return np.ascontiguousarray(np.clip(image + 0.5, 0, 255).astype(np.uint8))
