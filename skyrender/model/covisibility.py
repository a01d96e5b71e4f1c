"""Stage 1c — co-visibility learning (Naval 2000, section 2.4).

Cameras are placed on a regular grid at camera height over the DEM. From each,
a feature point is a *skyline feature* when it is visible (an unobstructed
line of sight) and lies on the horizon at its azimuth: a ray a little above it
(``horizon_tol_deg``) sees only sky. Counting over all viewpoints gives
P(pivot) (how often a pivot is a skyline feature) and P(peak | pivot).
Two batched Mitsuba ray tests per (viewpoint, feature) pair, no rendering.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..progress import progress as progress_bar
from ..render import Terrain
from ..render.visibility import line_of_sight


@dataclass(frozen=True)
class CovisibilityParams:
    spacing: float = 1000.0  # metres between sampled viewpoints
    height: float = 2.0  # camera height above ground (m)
    max_range: float = 40_000.0  # features further away are not counted (m)
    min_range: float = 200.0  # nor nearer ones: they tower over the camera (m)
    horizon_tol_deg: float = 0.05  # how far above the feature the sky must begin


@dataclass(frozen=True)
class Covisibility:
    """Counts and probabilities over the sampled viewpoints.

    n_viewpoints : viewpoints sampled.
    together : (F, F) int, viewpoints where features f and g both are (symmetric).
        The paper needs the pivots' rows; the localizer's minor-peak triples use the rest.
    """

    n_viewpoints: int
    together: np.ndarray

    @property
    def seen(self) -> np.ndarray:
        """(F,) int, viewpoints where each feature is a skyline feature (the diagonal of ``together``)."""
        return np.diagonal(self.together)

    def p_pivot(self, pivot_index: np.ndarray) -> np.ndarray:
        """P(pivot): share of viewpoints where each pivot is a skyline feature."""
        return self.seen[pivot_index] / max(self.n_viewpoints, 1)

    def p_given_pivot(self, pivot_index: np.ndarray) -> np.ndarray:
        """(P, F) P(feature | pivot); 0 where the pivot was never seen."""
        denom = self.seen[pivot_index][:, None].astype(np.float64)
        rows = self.together[pivot_index]
        return np.divide(rows, denom, out=np.zeros(rows.shape), where=denom > 0)


def viewpoint_grid(dem, spacing: float, height: float) -> np.ndarray:
    """(V, 3) camera positions on a regular grid over a DEM, ``height`` above its ground; none on terrain
    its loading invented (:attr:`~skyrender.dem.DEM.invented`: a missing tile, no data outside an outline),
    where no camera stands and no statistic or far horizon means anything."""
    xmin, xmax, ymin, ymax = dem.extent
    xs = np.arange(xmin + spacing / 2, xmax, spacing)
    ys = np.arange(ymin + spacing / 2, ymax, spacing)
    xx, yy = np.meshgrid(xs, ys)
    x, y = xx.ravel(), yy.ravel()
    if dem.invented is not None:
        keep = ~dem.is_invented(x, y)
        x, y = x[keep], y[keep]
    return np.column_stack([x, y, dem.ground(x, y) + height])


def pairs_in_range(cameras: np.ndarray, points: np.ndarray, min_range: float, max_range: float):
    """(camera, point) index pairs whose horizontal distance d (m) lies within [min_range,
    max_range], in row-major order, and d. A k-d tree finds them without forming all V x F
    pairs (9,000 features and 44,000 viewpoints on 2 x 2 tiles); d is the same ``hypot``."""
    from scipy.spatial import cKDTree

    if len(cameras) == 0 or len(points) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    near = cKDTree(cameras[:, :2]).sparse_distance_matrix(cKDTree(points[:, :2]), max_range * (1 + 1e-9) + 1e-6,
                                                           output_type="ndarray")
    v, f = near["i"].astype(np.int64), near["j"].astype(np.int64)
    order = np.argsort(v * len(points) + f, kind="stable")
    v, f = v[order], f[order]
    d = np.hypot(*(points[f, :2] - cameras[v, :2]).T)
    keep = (d >= min_range) & (d <= max_range)
    return v[keep], f[keep], d[keep]


def skyline_features(terrain: Terrain, cameras: np.ndarray, features: np.ndarray,
                     params: CovisibilityParams) -> np.ndarray:
    """(V, F) bool: is feature f a skyline feature seen from camera v?"""
    out = np.zeros((len(cameras), len(features)), dtype=bool)
    v, f, d = pairs_in_range(cameras, features, params.min_range, params.max_range)
    if len(v) == 0:
        return out
    cam, feat = cameras[v], features[f]
    visible = line_of_sight(terrain, cam, feat, lift_m=0.0)
    v, f, d, cam, feat = v[visible], f[visible], d[visible], cam[visible], feat[visible]
    # the sky must begin just above the feature: lift its direction by the tolerance
    seen = feat.copy()
    seen[:, 2] -= terrain.c * d ** 2  # as the camera sees it
    direction = seen - cam
    horiz = np.hypot(direction[:, 0], direction[:, 1])
    elev = np.arctan2(direction[:, 2], horiz) + np.radians(params.horizon_tol_deg)
    above = np.column_stack([direction[:, 0], direction[:, 1], horiz * np.tan(elev)])
    out[v, f] = ~terrain.ray_test(cam, above)
    return out


def learn_covisibility(terrain: Terrain, features: np.ndarray, params: CovisibilityParams = CovisibilityParams(),
                       progress: bool = False, max_pairs: int = 2_000_000) -> Covisibility:
    """Accumulate skyline-feature statistics over a grid of viewpoints.

    features : (F, 3) feature points (m).
    Deterministic; chunks of viewpoints bound the memory.
    """
    from scipy import sparse

    cameras = viewpoint_grid(terrain.dem, params.spacing, params.height)
    cameras = cameras[np.isfinite(cameras[:, 2])]
    F = len(features)
    seen_from = []  # per chunk, the sparse (cameras, F) skyline-feature matrix
    chunk = max(1, max_pairs // max(F, 1))
    for s in progress_bar(range(0, len(cameras), chunk), "co-visibility", progress, unit="chunk", leave=False):
        sky = skyline_features(terrain, cameras[s : s + chunk], features, params)
        seen_from.append(sparse.csr_matrix(sky, dtype=np.int64))
    # together = S^T S over all cameras. A camera sees tens of the F features on its skyline, so the
    # sparse product costs little where a dense one costs V F^2 (100 s for 2 x 2 tiles' 9,000 features)
    seen = sparse.vstack(seen_from, format="csr") if seen_from else sparse.csr_matrix((0, F), dtype=np.int64)
    return Covisibility(len(cameras), (seen.T @ seen).toarray())  # int64 already: no F x F copy
