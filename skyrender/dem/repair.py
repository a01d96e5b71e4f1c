"""Void filling and spike repair for elevation grids.

A single bad cell (32767, -32768, a sensor spike) becomes a phantom ridge
in every rendered skyline, so bad cells are found, counted and replaced by
interpolation from their good neighbours (GDAL's inverse-distance fill).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..errors import InputError
from .grid import RepairReport

#: Elevations outside this range are not terrain on Earth (sentinels like
#: 32767, -32768, -9999 land here). Metres.
PLAUSIBLE_RANGE_M = (-500.0, 9000.0)


def spike_threshold_m(cell_size_m: float) -> float:
    """Height (m) by which a cell must stand out of its 5 x 5 neighbourhood
    median to count as a spike. Real summits stand out by roughly one cell
    size (45 degree slopes); three cell sizes plus 100 m is beyond any rock."""
    return 100.0 + 3.0 * cell_size_m


def find_spikes(z: np.ndarray, cell_size_m: float, valid: np.ndarray) -> np.ndarray:
    """Boolean mask of cells far above (or, by twice as much, below) their
    5 x 5 neighbourhood median. Pits get the laxer test because narrow real
    gorges are deep at 90 m cells, and a pit never makes a phantom ridge."""
    filled = _fill(z, valid)
    threshold = spike_threshold_m(cell_size_m)
    # The median lies between the window's minimum and maximum, so only cells that far above
    # their window's minimum (or below its maximum) can be spikes (pits): the median is taken
    # there alone, the same as ``ndimage.median_filter(size=5, mode="nearest")`` but ~30x faster.
    candidate = ((filled - ndimage.minimum_filter(filled, size=5, mode="nearest") > threshold)
                 | (filled - ndimage.maximum_filter(filled, size=5, mode="nearest") < -2.0 * threshold))
    rows, cols = np.nonzero(candidate)
    windows = np.lib.stride_tricks.sliding_window_view(np.pad(filled, 2, mode="edge"), (5, 5))
    residual = filled[rows, cols] - np.median(windows[rows, cols].reshape(len(rows), 25), axis=1)
    spikes = np.zeros(z.shape, bool)
    spikes[rows, cols] = (residual > threshold) | (residual < -2.0 * threshold)
    return valid & spikes


def _fill(z: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Interpolate the invalid cells of z from the valid ones."""
    if valid.all():
        return z.astype(np.float64, copy=True)
    if not valid.any():
        raise InputError("DEM has no valid elevation at all")
    from rasterio.fill import fillnodata

    src = np.where(valid, z, 0.0).astype(np.float32)
    out = fillnodata(src, mask=valid.astype(np.uint8), max_search_distance=float(max(z.shape)), smoothing_iterations=0)
    out = out.astype(np.float64)
    still = ~np.isfinite(out)
    if still.any():  # fall back to the nearest valid cell
        idx = ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
        out[still] = z[tuple(i[still] for i in idx)]
    out[valid] = z[valid]
    return out


def repair_elevation(z: np.ndarray, cell_size_m: float, nodata_mask: np.ndarray | None = None):
    """Fill voids and repair spikes.

    Parameters
    ----------
    z : (rows, cols) elevations in metres (any float/int dtype; NaN = void).
    cell_size_m : cell size in metres (sets the spike threshold).
    nodata_mask : True where the file declared no data.

    Returns
    -------
    (z_fixed float64 array, RepairReport)
    """
    z = np.asarray(z, dtype=np.float64)
    void = ~np.isfinite(z)
    if nodata_mask is not None:
        void |= nodata_mask
    implausible = ~void & ((z < PLAUSIBLE_RANGE_M[0]) | (z > PLAUSIBLE_RANGE_M[1]))
    valid = ~void & ~implausible
    spikes = find_spikes(np.where(valid, z, 0.0), cell_size_m, valid)
    bad_spikes = implausible | spikes
    fixed = _fill(np.where(valid & ~spikes, z, 0.0), valid & ~spikes)
    notes = []
    if void.any():
        notes.append(f"filled {int(void.sum())} void cells")
    if bad_spikes.any():
        notes.append(f"repaired {int(bad_spikes.sum())} spike cells")
    return fixed, RepairReport(int(void.sum()), int(bad_spikes.sum()), tuple(notes))
