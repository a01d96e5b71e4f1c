"""Stage 3c — hypotheses from the far horizons (beyond the paper).

Three-point hypotheses need three of the photo's skyline peaks to be model
feature points; on some views they are not (a near ridge fills part of the
frame, or the matched peaks sit far apart). This stage needs no peaks: the
photo's skyline, turned into directions (azimuth relative to the optical axis,
elevation; camera assumed level), is compared with the Model Horizon Database's
far horizon around every grid centre at every azimuth bin — one FFT
cross-correlation per term for all azimuths at once. The camera's tilt, swing
and the level assumption's error are absorbed by fitting, per (centre,
azimuth), elevation offset + a alpha + b alpha^2 (alpha the relative azimuth, rad)
by weighted least squares: the cost is the mean squared residual (deg^2).

For real photographs (``LocalizeParams.for_photos``) the skyline is turned into
directions for several tilts (a camera looking up 20-30 deg at a ridge maps its columns
to azimuths quite unlike a level one) and only offset + slope are fitted: the curvature
term let wrong horizons fit as well as the right one.

A near ridge in the photo does not appear in a far horizon, so besides the whole
skyline, windows of it (its left or right part) are matched too, and each
window's best (centre, azimuth) pairs become poses for verification.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft

from ..blocks import in_blocks
from ..camera import Intrinsics, pixel_directions
from ..model import Horizons
from .pose_solver import camera_centres

#: Horizon centres per block of :func:`horizon_costs` (blocks run on all cores, their temporaries
#: small enough to stay in the cache).
COST_BLOCK_ROWS = 2048

#: Windows of the photo's skyline matched on their own (fractions of its azimuth span).
WINDOWS = ((0.0, 1.0), (0.0, 0.65), (0.35, 1.0), (0.0, 0.5), (0.5, 1.0))


@dataclass(frozen=True)
class HorizonSearchParams:
    windows: tuple = WINDOWS
    per_window: int = 200  # best (centre, azimuth) pairs kept per window
    min_bins: int = 12  # a window needs this many azimuth bins of skyline
    tilts: tuple = (0.0,)  # camera tilts (deg) the skyline is turned into directions for (photos look up at ridges)
    terms: int = 3  # fitted per (centre, azimuth): elevation offset, + slope (swing), + curvature (the level error)
    max_swing_deg: float = math.inf  # the slope fitted stays within what this camera roll (deg) gives
    rank_by_cost: bool = False  # refine the best by this search's own cost too, not only by verification score


def skyline_directions(skyline: np.ndarray, weights: np.ndarray, intrinsics: Intrinsics,
                       bin_deg: float, tilt: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The photo's skyline (W,) as elevation angles (deg) on azimuth bins (bin_deg)
    relative to the optical axis, for a camera tilted ``tilt`` deg (up positive) and no
    swing: (bins (n,) int, elevation (n,), weights (n,)). Columns without terrain (NaN)
    are left out."""
    u = np.arange(len(skyline)) + 0.5
    good = np.isfinite(skyline)
    if good.sum() < 2:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    d = pixel_directions(u[good], skyline[good], np.array([0.0, 0.0, 0.0, 0.0, tilt, 0.0]), intrinsics)
    az = np.degrees(np.arctan2(d[:, 0], d[:, 1]))
    el = np.degrees(np.arcsin(np.clip(d[:, 2], -1.0, 1.0)))
    bins = np.arange(np.ceil(az.min() / bin_deg), np.floor(az.max() / bin_deg) + 1).astype(np.int64)
    return bins, np.interp(bins * bin_deg, az, el), np.interp(bins * bin_deg, az, weights[good])


def horizon_costs(spectra: tuple[np.ndarray, np.ndarray], n_bins: int, bins: np.ndarray, elevation: np.ndarray,
                  weights: np.ndarray, bin_deg: float, terms: int = 3, max_swing_deg: float = math.inf):
    """Weighted mean squared residual (deg^2) of every (centre, azimuth) after the
    fit of offset + a alpha + b alpha^2 (the first ``terms`` of them), (N, n_bins); and
    a function giving the fitted offset (deg) at flat indices of it. With ``max_swing_deg``
    finite the slope a is held within the slope a camera rolled that far gives (tan(roll)
    deg per deg), the other terms fitted for the held slope: a least-squares fit's cost grows
    by d^2 / (gram^-1)_11 for its slope moved by d, the others moving with it.

    The fit runs in the basis 1, alpha, alpha^2 made orthonormal under the weights
    (:func:`orthonormal_basis`): the same fit, but the float32 correlations then need no
    cancellation between huge terms. In the raw basis a window 15-20 deg wide has a gram
    inverse of order 10^5, and the costs came out wrong by up to 0.025 deg^2 where the
    right ones are 0.002 (negative costs, the ranking noise).

    spectra : rfft over azimuth of the horizons P (N, n_bins) and of P^2.
    bins, elevation, weights : the photo's skyline (:func:`skyline_directions`).
    Azimuth bin p means the optical axis points at p * bin_deg.
    The search itself keeps only the best of these (:func:`best_horizon_fits`, the same values).
    """
    fit = _HorizonFit(spectra, n_bins, bins, elevation, weights, bin_deg, terms, max_swing_deg)
    N = spectra[0].shape[0]
    cost = np.empty((N, n_bins), np.float32)
    r = [np.empty((N, n_bins), np.float32) for _ in range(terms)]

    def rows(lo: int, hi: int) -> None:
        cost[lo:hi], rk = fit.rows(lo, hi)
        for k in range(terms):
            r[k][lo:hi] = rk[k]

    in_blocks(N, COST_BLOCK_ROWS, rows)
    return cost, lambda flat: fit.offset([r[k].ravel()[flat] for k in range(terms)])


def best_horizon_fits(spectra: tuple[np.ndarray, np.ndarray], n_bins: int, bins: np.ndarray, elevation: np.ndarray,
                      weights: np.ndarray, bin_deg: float, k: int, terms: int = 3,
                      max_swing_deg: float = math.inf) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``k`` best (centre, azimuth) fits of :func:`horizon_costs` (same arguments): their flat
    indices into its (N, n_bins) costs, ordered as :func:`smallest` orders them, their costs (deg^2)
    and fitted offsets (deg), to the bit those of the whole arrays. Each block of centres keeps its
    own ``k`` best (the whole's best ``k`` are among them), so the (N, n_bins) costs and fit
    coefficients are never stored (3 x 80 MB a window for a CH1 model's 20 M pairs, written and paged
    in anew each time) nor searched in one thread: the photo preset's search at one fov (5 tilts x
    5 windows) 1.5x faster, the same poses (experiments/ch1/search-speed/)."""
    fit = _HorizonFit(spectra, n_bins, bins, elevation, weights, bin_deg, terms, max_swing_deg)
    N = spectra[0].shape[0]
    blocks: dict[int, tuple] = {}

    def rows(lo: int, hi: int) -> None:
        cost, rk = fit.rows(lo, hi)
        best = smallest(cost, k)
        blocks[lo] = (best + lo * n_bins, cost.ravel()[best], fit.offset([rk[j].ravel()[best] for j in range(terms)]))

    in_blocks(N, COST_BLOCK_ROWS, rows)
    if not blocks:
        return np.zeros(0, np.int64), np.zeros(0, np.float32), np.zeros(0, np.float32)
    flat, cost, offset = (np.concatenate([blocks[lo][i] for lo in sorted(blocks)]) for i in range(3))
    pick = np.lexsort((flat, cost))[:k]
    return flat[pick], cost[pick], offset[pick]


class _HorizonFit:
    """The far-horizon fit of one skyline window (:func:`horizon_costs`), worked out block of centres by block."""

    def __init__(self, spectra, n_bins, bins, elevation, weights, bin_deg, terms, max_swing_deg):
        self.spec_p, self.spec_p2 = spectra
        self.n_bins, self.terms = n_bins, terms
        alpha = np.radians(bins * bin_deg)
        X = np.column_stack([np.ones_like(alpha), alpha, alpha ** 2])[:, :terms]
        # Q = X T, orthonormal under the weights: the fit removes |Q^T W (P - e)|^2, and the raw
        # coefficients are T times those of Q
        T = orthonormal_basis(X, weights)
        Q = X @ T
        idx = bins % n_bins

        def spread(values: np.ndarray) -> np.ndarray:
            g = np.zeros(n_bins)
            np.add.at(g, idx, values)
            return np.conj(scipy.fft.rfft(g)).astype(np.complex64)

        w = weights
        # sum w (P - e)^2 = sum w P^2 - 2 sum w e P + sum w e^2
        self.g_p2, self.g_p = spread(w), spread(-2.0 * w * elevation)
        self.sum_we2 = np.float32((w * elevation ** 2).sum())
        # r = Q^T W (P - e) per (centre, azimuth); the fit removes |r|^2
        self.g_r = [spread(w * Q[:, k]) for k in range(terms)]
        self.sum_r = [np.float32((w * Q[:, k] * elevation).sum()) for k in range(terms)]
        # the raw offset and slope are the rows T[0] and T[1] applied to r; holding the slope moves the
        # cost by d^2 / |T[1]|^2 (|T[1]|^2 = (gram^-1)_11) and the offset by d T[0].T[1] / |T[1]|^2
        self.T = T.astype(np.float32)
        self.bounded = terms > 1 and math.isfinite(max_swing_deg)
        # deg per rad
        self.max_slope = np.float32(np.tan(np.radians(max_swing_deg)) * 180.0 / np.pi) if self.bounded else None
        self.slope_var = np.float32(self.T[1] @ self.T[1]) if terms > 1 else None
        self.norm = np.float32(max(float(w.sum()), 1e-9))

    def slope_excess(self, slope: np.ndarray) -> np.ndarray:
        """In place: how far each slope lies beyond the bound."""
        slope -= np.clip(slope, -self.max_slope, self.max_slope)
        return slope

    def rows(self, lo: int, hi: int) -> tuple[np.ndarray, list[np.ndarray]]:
        """Costs (hi - lo, n_bins) of centres lo:hi, and their fit coefficients r (``terms`` arrays
        of that shape). Every operation is row-wise, so blocks give the whole arrays' values to the
        bit, and a block's temporaries stay in the cache."""
        terms, T, n_bins = self.terms, self.T, self.n_bins

        def correlate(spec, conj_g):  # out[:, p] = sum_i P[:, i + p] g[i]
            return scipy.fft.irfft(spec[lo:hi] * conj_g, n=n_bins, axis=1, workers=1)

        c = scipy.fft.irfft(self.spec_p2[lo:hi] * self.g_p2 + self.spec_p[lo:hi] * self.g_p, n=n_bins, axis=1,
                            workers=1)
        c += self.sum_we2
        rk = []
        for k in range(terms):
            rk.append(correlate(self.spec_p, self.g_r[k]))
            rk[k] -= self.sum_r[k]
        term = np.empty_like(c)
        for k in range(terms):
            np.multiply(rk[k], rk[k], out=term)
            c -= term
        if self.bounded:
            excess = self.slope_excess(sum(T[1, k] * rk[k] for k in range(terms)))
            np.multiply(excess, excess, out=excess)
            excess *= np.float32(1.0 / self.slope_var)
            c += excess
        c /= self.norm
        return c, rk

    def offset(self, r: list[np.ndarray]) -> np.ndarray:
        """The fitted offset (deg) from fit coefficients r (``terms`` arrays, at some pairs)."""
        T = self.T
        offset = sum(T[0, k] * r[k] for k in range(self.terms))
        if self.bounded:
            offset -= self.slope_excess(sum(T[1, k] * r[k] for k in range(self.terms))) * (T[0] @ T[1] /
                                                                                            self.slope_var)
        return offset


def orthonormal_basis(X: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Upper-triangular T (k, k) such that the columns of X T (n, k) are orthonormal under
    ``weights``: (X T)^T W (X T) = I. From the Cholesky factor of the gram X^T W X (float64,
    a 1e-9 ridge as the raw fit had, so a window with fewer distinct bins than terms stays finite)."""
    gram = (X * weights[:, None]).T @ X + 1e-9 * np.eye(X.shape[1])
    return np.linalg.inv(np.linalg.cholesky(gram)).T


def centre_indices(horizons: Horizons, xy: np.ndarray) -> np.ndarray:
    """Indices of the horizon centres at positions ``xy`` (M, 2) (m; the x, y of poses
    :func:`horizon_poses` made); -1 where no centre lies within a metre."""
    if len(xy) == 0 or len(horizons) == 0:
        return np.zeros(len(xy), np.int64)
    from scipy.spatial import cKDTree

    d, i = cKDTree(horizons.centres[:, :2]).query(np.asarray(xy, np.float64)[:, :2])
    return np.where(d <= 1.0, i, -1).astype(np.int64)


def standable_centres(horizons: Horizons, dem, max_slope_deg: float) -> np.ndarray | None:
    """Indices of the horizon centres whose ground slopes at most ``max_slope_deg`` (deg,
    :meth:`DEM.slope_deg`): where a person can stand to take a photo; None (every centre) when
    the bound is infinite. On the 73 CH1 training-side photos the true positions' slopes on
    SRTM3 are 0-27 deg (median 12), the refined wrong candidates' median 20.5 deg, a quarter
    of them over 29 deg (``experiments/ch1/standable/``). A centre whose slope is unknown (NaN: on
    the DEM's outer cells) is kept, as :func:`~skyrender.localizer.pipeline.standable_mask` keeps
    such a pose."""
    if not math.isfinite(max_slope_deg):
        return None
    c = horizons.centres
    return np.flatnonzero(~(dem.slope_deg(c[:, 0], c[:, 1]) > max_slope_deg))


def smallest(cost: np.ndarray, k: int) -> np.ndarray:
    """Flat indices of the ``k`` smallest entries of ``cost`` (N, B), by cost then index (so ties
    are broken the same on every machine). The k-th smallest of the N row minima bounds them
    (the k rows with the lowest minima hold k entries at most that high), so one comparison
    pass leaves a few thousand candidates to sort instead of partitioning all N B entries
    (0.28 s for a CH1 model's 20 M, per window and tilt)."""
    k = min(k, cost.size)
    if k == 0:
        return np.zeros(0, np.int64)
    flat = cost.ravel()
    row_min = cost.min(axis=1)
    bound = np.partition(row_min, k - 1)[k - 1] if k <= len(row_min) else np.inf
    candidates = np.flatnonzero(flat <= bound) if np.isfinite(bound) else np.arange(flat.size)
    return candidates[np.lexsort((candidates, flat[candidates]))[:k]]


def horizon_poses(horizons: Horizons, skyline: np.ndarray, weights: np.ndarray, intrinsics: Intrinsics, dem,
                  height: float, params: HorizonSearchParams = HorizonSearchParams(),
                  centres: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Poses (K, 6) of the best (centre, azimuth) pairs of each window, camera ``height``
    m above the centre's ground, pan = azimuth, tilt = the tried tilt + fitted offset,
    swing 0; and their costs (K,) (deg^2). Empty when the skyline is too short for any
    window. ``centres``: indices of the horizon centres searched (None: every one); the
    search over a subset costs in proportion to its size."""
    n_bins = horizons.elevation.shape[1]
    if len(horizons) == 0:
        return np.zeros((0, 6)), np.zeros(0)
    spectra = horizons.spectra
    if centres is not None:
        centres = np.unique(np.asarray(centres, np.int64))  # ascending: ties still break by centre index
        if len(centres) == 0:
            return np.zeros((0, 6)), np.zeros(0)
        spectra = (spectra[0][centres], spectra[1][centres])
    flats, costs, tilts = [], [], []  # every window's best (centre, azimuth) pairs, in the order found
    for tilt in params.tilts:
        bins, elevation, w = skyline_directions(skyline, weights, intrinsics, horizons.bin_deg, tilt)
        if len(bins) < params.min_bins:
            continue
        frac = (bins - bins[0]) / max(bins[-1] - bins[0], 1)
        for lo, hi in params.windows:
            w_win = w * ((frac >= lo) & (frac <= hi))
            if np.count_nonzero(w_win) < params.min_bins:
                continue
            best, cost, offset = best_horizon_fits(spectra, n_bins, bins, elevation, w_win, horizons.bin_deg,
                                                   params.per_window, params.terms, params.max_swing_deg)
            flats.append(best)
            costs.append(cost)
            tilts.append(tilt + offset.astype(np.float64))
    if not flats:
        return np.zeros((0, 6)), np.zeros(0)
    flat, cost, tilt = np.concatenate(flats), np.concatenate(costs).astype(np.float64), np.concatenate(tilts)
    # one pose per (centre, azimuth): its lowest cost (the first found among equals), listed by cost, then by
    # where the pair was first found
    found = np.arange(len(flat))
    by_cost = np.lexsort((found, cost))
    keys, best_of_key = np.unique(flat[by_cost], return_index=True)
    pick = by_cost[best_of_key]
    _, first_seen = np.unique(flat, return_index=True)  # aligned with keys (both sorted by key)
    pick = pick[np.lexsort((first_seen, cost[pick]))]
    centre, azimuth = np.divmod(flat[pick], n_bins)
    if centres is not None:
        centre = centres[centre]
    xyz = camera_centres(dem, horizons.centres[centre, :2], height)
    poses = np.column_stack([xyz, azimuth * horizons.bin_deg, tilt[pick], np.zeros(len(pick))])
    return poses, cost[pick]
