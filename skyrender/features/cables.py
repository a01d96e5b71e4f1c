"""Cables across the sky, found and painted over before the skyline is extracted.

Power lines and ski-lift cables cross many mountain photos: thin dark curves with the same sky
on both sides. Both extractors take them for the skyline — the network learned that the sky is
the top of the frame down to the first dark edge, and the per-photo mixtures are seeded from the
sky region touching the top, which a cable cuts off — and a cable spans the frame, so the whole
skyline goes (issue 18; the CH1 masks count cables as sky, as the renderer's truth does).

A pixel belongs to a cable when a vertical closing of the lightness raises it by more than
``min_contrast`` (it is darker than what lies within ``max_width`` px above and below it, a thin
horizontal-ish line), the colours just beyond the line on either side agree (sky continues
behind it: a dark ridge has sky above and terrain below) and both are smooth. Only long such
lines count (``min_span`` of the frame's width, connected): a stretch of ridge between two
similar skies is short. The cables' pixels are filled in from their surroundings
(``cv2.inpaint``); everything else is left untouched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CableParams:
    max_width: int = 4  # px: thicker dark lines are not cables
    min_contrast: float = 8.0  # Lab L units the line is darker than the closing of its column
    max_side_difference: float = 4.0  # Lab units between the colours just above and just below the line
    max_side_texture: float = 2.0  # Lab L std (5 x 5) either side: the sky behind a cable is smooth
    min_span: float = 0.15  # share of the frame's width one connected line must cross


def cable_mask(image: np.ndarray, params: CableParams = CableParams()) -> np.ndarray:
    """(H, W) bool: the pixels of long thin dark lines crossing smooth sky in an RGB image (0-255)."""
    import cv2

    H, W = image.shape[:2]
    w = int(params.max_width)
    if H <= 2 * w + 2 or W < 2:
        return np.zeros((H, W), bool)
    lab = cv2.cvtColor(image.astype(np.float32) / 255.0, cv2.COLOR_RGB2Lab)
    L = lab[..., 0]
    closed = cv2.morphologyEx(L, cv2.MORPH_CLOSE, np.ones((2 * w + 1, 1), np.uint8))
    dark_line = closed - L > params.min_contrast
    if not dark_line.any():
        return dark_line
    mean = cv2.blur(L, (5, 5))
    smooth = cv2.blur(L * L, (5, 5)) - mean * mean < params.max_side_texture ** 2
    rows, cols = np.nonzero(dark_line)  # the tests below only where they can matter: a few % of the pixels
    sky_both_sides = np.zeros(len(rows), bool)
    # the sides are looked at just beyond the widest cable and further out: where two cables
    # run close, the nearer side of one is the other
    for r in range(w + 1, 3 * w + 2, w):
        # the colours compared only where both sides lie in the frame and are smooth, and no nearer side matched
        at = np.flatnonzero((rows >= r) & (rows < H - r) & ~sky_both_sides)
        up, down, c = rows[at] - r, rows[at] + r, cols[at]
        smooth_sides = smooth[up, c] & smooth[down, c]
        at, up, down, c = at[smooth_sides], up[smooth_sides], down[smooth_sides], c[smooth_sides]
        difference = lab[up, c] - lab[down, c]
        sky_both_sides[at] = np.einsum("ij,ij->i", difference, difference) < params.max_side_difference ** 2
    candidate = np.zeros((H, W), np.uint8)
    candidate[rows[sky_both_sides], cols[sky_both_sides]] = 1
    n, labels, stats, _ = cv2.connectedComponentsWithStats(candidate, connectivity=8)
    long_enough = np.flatnonzero(stats[:, cv2.CC_STAT_WIDTH] >= params.min_span * W)
    long_enough = long_enough[long_enough > 0]  # 0 is the background
    if len(long_enough) == 0:
        return np.zeros((H, W), bool)
    return np.isin(labels, long_enough) & dark_line


def remove_cables(image: np.ndarray, params: CableParams = CableParams()) -> tuple[np.ndarray, np.ndarray]:
    """(image with its cables painted over, their mask): :func:`cable_mask`, widened by a pixel
    for the lines' anti-aliased edges, filled in from around it (``cv2.inpaint``, Telea; an image
    of another dtype than uint8 channel by channel in float32, returned in its own dtype). The
    image itself is returned, not a copy, when it has no cable."""
    import cv2

    mask = cable_mask(image, params)
    if not mask.any():
        return image, mask
    wide = cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8))
    if image.dtype == np.uint8:
        return cv2.inpaint(np.ascontiguousarray(image), wide, 3, cv2.INPAINT_TELEA), wide.astype(bool)
    channels = np.asarray(image, np.float32)
    painted = np.dstack([cv2.inpaint(np.ascontiguousarray(channels[..., c]), wide, 3, cv2.INPAINT_TELEA)
                         for c in range(channels.shape[2])])
    return painted.astype(image.dtype), wide.astype(bool)
