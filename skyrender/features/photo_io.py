"""Reading the photographs users have: any size, gray/RGB/RGBA, 8 or 16 bit, phone
photos with their EXIF orientation applied (every output is in the upright frame), and
the field of view their EXIF focal length implies."""

from __future__ import annotations

import math
import os

import numpy as np

from ..camera import horizontal_fov
from ..errors import InputError
from ..io import captured_stderr

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
    try:
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the image ({exc.strerror or exc})") from None
    _check_complete(data, path)
    with captured_stderr() as complaint:  # libpng / libjpeg / OpenCV print their own lines
        image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
    if image is None:
        raise InputError(f"{path}: not an image that can be read")
    said = " ".join(complaint["text"].split())
    if said:  # decoded, but from damaged data: half an image would give a wrong skyline silently
        raise InputError(f"{path}: corrupt image data ({said[:120]})")
    return upright(as_rgb8(image, name=path, bgr=True), exif_orientation(path))


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _check_complete(data: np.ndarray, path: str) -> None:
    """InputError for a PNG or JPEG file cut off before its end marker (IEND, EOI): the
    decoder would print its own complaint on stderr and return half an image."""
    head = data[:8].tobytes()
    tail = data[-1024:].tobytes()
    if head == PNG_SIGNATURE and b"IEND" not in tail:
        raise InputError(f"{path}: truncated PNG file (no IEND chunk)")
    if head[:2] == b"\xff\xd8" and b"\xff\xd9" not in tail:
        raise InputError(f"{path}: truncated JPEG file (no end-of-image marker)")


# EXIF Orientation tag value -> (rotations by 90 degrees counter-clockwise, then flip left-right)
_ORIENTATION = {1: (0, False), 2: (0, True), 3: (2, False), 4: (2, True), 5: (1, True), 6: (3, False),
                7: (3, True), 8: (1, False)}
DIAGONAL_35MM = math.hypot(36.0, 24.0)  # mm: the diagonal a 35 mm-equivalent focal length refers to


def _exif(path: str) -> dict:
    """EXIF tags of an image file by name (empty where it has none or cannot be parsed)."""
    try:
        from PIL import ExifTags, Image

        with Image.open(path) as im:
            exif = im.getexif()
            tags = dict(exif)
            tags.update(exif.get_ifd(ExifTags.IFD.Exif))
        return {ExifTags.TAGS.get(k, k): v for k, v in tags.items()}
    except Exception:  # EXIF is optional; a photo with a broken EXIF block is still a photo
        return {}


def exif_orientation(path: str) -> int:
    """The EXIF Orientation tag (1-8), 1 where absent."""
    value = _exif(path).get("Orientation", 1)
    return int(value) if value in _ORIENTATION else 1


def upright(image: np.ndarray, orientation: int) -> np.ndarray:
    """The image turned upright for an EXIF Orientation value (1: as stored)."""
    turns, flip = _ORIENTATION.get(int(orientation), (0, False))
    out = np.rot90(image, turns)
    return np.ascontiguousarray(out[:, ::-1] if flip else out)


def is_camera_photo(path: str) -> bool:
    """True for a JPEG, or an image whose EXIF names a camera or a focal length: a real
    photograph, not a render (``localize --preset auto``)."""
    if os.path.splitext(path)[1].lower() in (".jpg", ".jpeg"):
        return True
    tags = _exif(path)
    return any(k in tags for k in ("Make", "Model", "FocalLength", "FocalLengthIn35mmFilm"))


def exif_fov(path: str) -> float | None:
    """Horizontal field of view (degrees) of the *upright* photo from its EXIF focal length.

    ``FocalLengthIn35mmFilm`` refers to the 35 mm frame's diagonal (43.3 mm), so the
    focal length in pixels is f35 * (image diagonal in px) / 43.3 whichever way the photo
    is turned; without it, ``FocalLength`` with ``FocalPlaneXResolution`` (pixels per unit
    of ``FocalPlaneResolutionUnit``) gives it. None where EXIF says neither.
    """
    tags = _exif(path)
    try:
        from PIL import Image

        with Image.open(path) as im:
            w, h = im.size
    except Exception:
        return None
    if exif_orientation(path) in (5, 6, 7, 8):
        w, h = h, w
    f_px = None
    f35 = tags.get("FocalLengthIn35mmFilm")
    if f35 and float(f35) > 0:
        f_px = float(f35) * math.hypot(w, h) / DIAGONAL_35MM
    else:
        f_mm, xres = tags.get("FocalLength"), tags.get("FocalPlaneXResolution")
        unit_mm = {2: 25.4, 3: 10.0, 4: 1.0}.get(int(tags.get("FocalPlaneResolutionUnit", 2) or 2), 25.4)
        if f_mm and xres and float(f_mm) > 0 and float(xres) > 0:
            # FocalPlaneXResolution counts pixels of the stored (un-rotated) width
            f_px = float(f_mm) * float(xres) / unit_mm
    if not f_px or not math.isfinite(f_px):
        return None
    return horizontal_fov(w, f_px)


def given_skyline(width: int, height: int, skyline_path=None, sky_mask_path=None, terrain_mask_path=None) -> np.ndarray:
    """The skyline (W,) float64 of a ``width`` x ``height`` (upright) photo as a person gives it, in place of the
    extracted one: a skyline file (``skyline_path``; CONTRACT.md, *Skyline*: ``.npy`` float64 or a JSON list with
    null for NaN, as ``skyrender skyline --out`` writes it, perhaps corrected by hand), a sky mask (``sky_mask_path``:
    an image of the photo's size, EXIF orientation applied, white = sky: grey level above 127) or a terrain mask
    (``terrain_mask_path``: the same with white = terrain, as the CH1 and GeoPose3K masks are). Exactly one.
    Baatz et al.'s CH1 results used skylines "either automatic or easily supported by an operator for challenging
    pictures"; this is that operator's way in. InputError names what does not fit the photo."""
    from ..io import load_skyline
    from .skyline import skyline_of_terrain

    if sum(p is not None for p in (skyline_path, sky_mask_path, terrain_mask_path)) != 1:
        raise InputError("give one of a skyline file, a sky mask and a terrain mask")
    mask_path = sky_mask_path if sky_mask_path is not None else terrain_mask_path
    if mask_path is not None:
        kind = "sky" if sky_mask_path is not None else "terrain"
        mask = load_photo(mask_path)
        if mask.shape[:2] != (height, width):
            raise InputError(f"{os.fspath(mask_path)}: the {kind} mask is {mask.shape[1]} x {mask.shape[0]} px, "
                             f"the photo {width} x {height} (upright)")
        white = mask.mean(axis=2) > 127.0
        sky = white if kind == "sky" else ~white
        if not sky.any():
            raise InputError(f"{os.fspath(mask_path)}: the {kind} mask marks no sky "
                             f"({'white' if kind == 'sky' else 'black'} pixels)")
        return skyline_of_terrain(~sky)
    sky = load_skyline(skyline_path)
    if sky.shape != (width,):
        raise InputError(f"{os.fspath(skyline_path)}: the skyline has {sky.size} values, the photo {width} columns "
                         "(upright)")
    if np.isinf(sky).any() or (sky < 0).any() or (sky > height).any():
        raise InputError(f"{os.fspath(skyline_path)}: skyline values must lie in [0, {height}] (the photo's rows) "
                         "or be NaN (null)")
    if np.isnan(sky).all():
        raise InputError(f"{os.fspath(skyline_path)}: the skyline is all sky (NaN): nothing to localize from")
    return sky


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
    if image.dtype == np.uint8 and image.shape[2] != 4:  # the common case: no float copy of a large photo
        out = np.repeat(image, 3, axis=2) if image.shape[2] == 1 else (image[..., ::-1] if bgr else image)
        return np.ascontiguousarray(out)
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
