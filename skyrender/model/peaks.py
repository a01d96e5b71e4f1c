"""Stage 1a — DEM peaks: the Model Peak and Model Feature Point Databases.

A *major* peak is the highest cell within a wide radius, a *minor* peak the
highest within a small radius (Naval 2000, section 2.1). Radii are in metres,
so the same defaults serve 10 m and 90 m cells. Locations are refined below
the cell size by a quadratic fit to the 3 x 3 neighbourhood.

Prominence here is measured within a window of the major radius around the
peak: the drop from the summit to the highest col that connects it to higher
ground or to the window's edge. It is a lower bound on the topographic
prominence of the window's highest peak, and exact for lower peaks whose key
col lies inside the window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..dem import DEM


@dataclass(frozen=True)
class PeakParams:
    """Peak detection parameters (metres)."""

    major_radius: float = 1800.0
    minor_radius: float = 650.0
    min_prominence: float = 0.0
    min_prominence_major: float = 0.0


@dataclass(frozen=True)
class PeakTable:
    """Feature points (major and minor peaks), one row each, sorted by elevation (highest first).

    id : stable id, ``P0000``-style index into the table (int).
    x, y : world position (m), refined below the cell size.
    z : summit elevation (m) from the quadratic fit (never below the cell's value).
    row, col : the summit cell.
    prominence : within the major-radius window (m).
    major : True for major peaks (pivots).
    """

    id: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    row: np.ndarray
    col: np.ndarray
    prominence: np.ndarray
    major: np.ndarray

    def __len__(self) -> int:
        return len(self.id)

    @property
    def xyz(self) -> np.ndarray:
        return np.column_stack([self.x, self.y, self.z])

    def subset(self, mask) -> "PeakTable":
        return PeakTable(*(getattr(self, f)[mask] for f in self.__dataclass_fields__))


def disk(radius_cells: float) -> np.ndarray:
    """Boolean disk footprint of the given radius in cells (at least 3 x 3)."""
    r = max(1, int(np.floor(radius_cells)))
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    return xx**2 + yy**2 <= max(radius_cells, 1.0) ** 2


def local_maxima(z: np.ndarray, radius_cells: float) -> np.ndarray:
    """(row, col) of cells that are the highest within ``radius_cells`` (a disk; one cell
    per plateau), excluding the outer border (a maximum there is a cut-off, not a summit).

    Two steps keep this fast for wide radii: a separable square maximum filter over the
    square inscribed in the disk gives candidates, then each is checked on its disk.
    """
    half = max(1, int(np.floor(radius_cells / np.sqrt(2.0))))
    is_max = (z >= ndimage.maximum_filter(z, size=2 * half + 1, mode="nearest"))
    is_max &= z >= ndimage.maximum_filter(z, size=3, mode="nearest")
    is_max[0, :] = is_max[-1, :] = is_max[:, 0] = is_max[:, -1] = False
    labels, n = ndimage.label(is_max, structure=np.ones((3, 3)))
    if n == 0:
        return np.zeros((0, 2), dtype=np.int64)
    # one cell per plateau: the labelled cell nearest the plateau's centroid
    centres = np.array(ndimage.center_of_mass(is_max, labels, np.arange(1, n + 1)))
    rows, cols = np.nonzero(labels)
    lab = labels[rows, cols] - 1
    d = (rows - centres[lab, 0]) ** 2 + (cols - centres[lab, 1]) ** 2
    order = np.lexsort((d, lab))
    first = order[np.r_[True, lab[order][1:] != lab[order][:-1]]]
    candidates = np.column_stack([rows[first], cols[first]])
    foot = disk(radius_cells)
    r = (foot.shape[0] - 1) // 2
    padded = np.pad(z, r, mode="edge")
    keep = [z[i, j] >= padded[i : i + 2 * r + 1, j : j + 2 * r + 1][foot].max() for i, j in candidates]
    return candidates[np.array(keep, dtype=bool)]


def refine_quadratic(z: np.ndarray, rc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sub-cell summit by a least-squares quadratic on the 3 x 3 neighbourhood.

    Returns (d_row, d_col, z_peak): offsets in cells (clipped to +-0.5) and the fitted
    summit elevation (never below the cell's own value).
    """
    if len(rc) == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    dy, dx = np.mgrid[-1:2, -1:2]
    dx, dy = dx.ravel().astype(float), dy.ravel().astype(float)
    A = np.column_stack([np.ones(9), dx, dy, dx**2, dx * dy, dy**2])
    pinv = np.linalg.pinv(A)  # (6, 9)
    r, c = rc[:, 0], rc[:, 1]
    patches = np.stack([z[r + j, c + i] for j, i in zip(dy.astype(int), dx.astype(int))], axis=1)
    a0, b, cc, d, e, f = pinv @ patches.T  # each (n,)
    det = 4 * d * f - e**2
    ok = (det > 1e-12) & (d < 0) & (f < 0)
    safe = np.where(ok, det, 1.0)
    ox = np.where(ok, (-2 * f * b + e * cc) / safe, 0.0)
    oy = np.where(ok, (-2 * d * cc + e * b) / safe, 0.0)
    ox, oy = np.clip(ox, -0.5, 0.5), np.clip(oy, -0.5, 0.5)
    z_fit = a0 + b * ox + cc * oy + d * ox**2 + e * ox * oy + f * oy**2
    return oy, ox, np.maximum(z_fit, z[r, c])


def window_prominence(z: np.ndarray, rc: np.ndarray, radius_cells: float, tol_m: float = 0.5) -> np.ndarray:
    """Prominence (m) of each peak within a square window of half-size ``radius_cells``.

    Bisection on the flood level L: the highest L at which the summit's connected
    region of {z >= L} reaches higher ground or the window's edge is the key col.
    """
    out = np.zeros(len(rc))
    h = max(2, int(np.ceil(radius_cells)))
    rows, cols = z.shape
    for i, (r, c) in enumerate(rc):
        r0, r1, c0, c1 = max(0, r - h), min(rows, r + h + 1), max(0, c - h), min(cols, c + h + 1)
        w = z[r0:r1, c0:c1]
        pr, pc = r - r0, c - c0
        peak = w[pr, pc]
        target = w > peak
        target[0, :] = target[-1, :] = target[:, 0] = target[:, -1] = True
        lo, hi = float(w.min()), float(peak)  # connected at lo; not (trivially) at peak height
        while hi - lo > tol_m:
            mid = 0.5 * (lo + hi)
            labels, _ = ndimage.label(w >= mid)
            if (labels[target] == labels[pr, pc]).any():
                lo = mid
            else:
                hi = mid
        out[i] = peak - lo
    return out


def find_peaks(dem: DEM, params: PeakParams = PeakParams()) -> PeakTable:
    """Major and minor peaks of a DEM (the Model Feature Point Database).

    Every major peak is also a minor one; ``table.major`` marks the pivots.
    """
    cell = float(np.sqrt(np.prod(dem.cell_size)))
    z = dem.elevation
    minor_rc = local_maxima(z, params.minor_radius / cell)
    major_rc = local_maxima(z, params.major_radius / cell)
    cols = z.shape[1]
    minor_cells, major_cells = minor_rc[:, 0] * cols + minor_rc[:, 1], major_rc[:, 0] * cols + major_rc[:, 1]
    cells = np.union1d(minor_cells, major_cells)  # a major peak is a minor one too
    rc = np.column_stack([cells // cols, cells % cols])
    is_major = np.isin(cells, major_cells)
    prominence = window_prominence(z, rc, params.major_radius / cell)
    keep = (prominence > 0) & (prominence >= params.min_prominence) & (~is_major | (prominence >= params.min_prominence_major))
    rc, is_major, prominence = rc[keep], is_major[keep], prominence[keep]
    d_row, d_col, z_peak = refine_quadratic(z, rc)
    x = dem.x_centres[rc[:, 1]] + d_col * dem.cell_size[0]
    y = dem.y_centres[rc[:, 0]] - d_row * dem.cell_size[1]
    order = np.lexsort((x, y, -z_peak))  # highest first, ties broken by position: deterministic
    n = len(order)
    return PeakTable(np.arange(n), x[order], y[order], z_peak[order], rc[order, 0], rc[order, 1],
                     prominence[order], is_major[order])
