"""Stage 2b — skyline peaks (Naval 2000, section 2.1).

The skyline is smoothed, split into intervals where its second derivative
(of height, i.e. -v) is negative, and each interval is taken as one
Gaussian-shaped bump: its apex is the highest point (u refined by a parabola
through the three smoothed samples around it, v the highest raw sample within
two columns, since smoothing flattens a sharp summit), its size the area between the curve and
the chord joining the interval's ends. Intervals that touch the image border
or a gap (NaN) are cut-offs, not peaks, and are dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d


@dataclass(frozen=True)
class SkylinePeak:
    """u, v: apex (px, image coordinates); size: area (px^2); width: interval length (px);
    aspect: apex height over the interval's lower end, per half width (a conifer or a
    post in front is far steeper than a mountain: aspect > 1.5)."""

    u: float
    v: float
    size: float
    width: float
    aspect: float = 0.0


def skyline_peaks(skyline: np.ndarray, n: int = 6, smooth_px: float = 2.0, min_size: float = 2.0,
                  max_aspect: float = np.inf) -> list[SkylinePeak]:
    """The ``n`` largest peaks of a skyline (v per column, NaN = no terrain), largest first;
    peaks steeper than ``max_aspect`` (foreground objects) left out."""
    sky = np.asarray(skyline, dtype=np.float64)
    peaks: list[SkylinePeak] = []
    finite = np.isfinite(sky)
    # each finite run of columns is analysed on its own
    edges = np.flatnonzero(np.diff(np.r_[0, finite.astype(int), 0]))
    for start, stop in zip(edges[::2], edges[1::2]):
        if stop - start < 5:
            continue
        h = -gaussian_filter1d(sky[start:stop], smooth_px, mode="nearest")
        d2 = np.gradient(np.gradient(h))
        concave = d2 < 0
        runs = np.flatnonzero(np.diff(np.r_[0, concave.astype(int), 0]))
        for a, b in zip(runs[::2], runs[1::2]):
            if a == 0 or b == len(h):  # touches the border or a gap: a cut-off
                continue
            seg = h[a:b]
            k = int(np.argmax(seg)) + a
            if k == a or k == b - 1:  # monotone interval: a shoulder, not a bump
                continue
            y0, y1, y2 = h[k - 1], h[k], h[k + 1]
            denom = y0 - 2 * y1 + y2
            offset = 0.5 * (y0 - y2) / denom if denom < 0 else 0.0
            offset = float(np.clip(offset, -0.5, 0.5))
            # the apex height from the unsmoothed skyline: smoothing flattens sharp summits
            raw = sky[start + max(k - 2, 0) : start + min(k + 3, len(h))]
            apex_h = float(-np.nanmin(raw))
            x = np.arange(a, b)
            chord = h[a] + (h[b - 1] - h[a]) * (x - a) / max(b - 1 - a, 1)
            size = float(np.sum(np.clip(seg - chord, 0, None)))
            if size < min_size:
                continue
            aspect = (apex_h - min(h[a], h[b - 1])) / max(0.5 * (b - a), 1.0)
            if aspect > max_aspect:
                continue
            peaks.append(SkylinePeak(float(start + k + offset + 0.5), float(-apex_h), size, float(b - a),
                                     float(aspect)))
    peaks.sort(key=lambda p: -p.size)
    return peaks[:n]
