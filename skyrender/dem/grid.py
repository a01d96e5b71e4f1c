"""The DEM object: an elevation grid in a projected, metric world frame.

Conventions (README): x = east, y = north, z = up, metres. Cells are
areas (GDAL): ``transform`` maps (col, row) of the *outer corner* of the
top-left cell; cell centres lie half a cell inside. Row 0 is the northern
edge. The terrain surface is the triangle mesh with a vertex at every cell
centre and two triangles per quad, split along the quad's south-west to
north-east diagonal; :meth:`DEM.ground` evaluates its height.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from affine import Affine

from ..errors import InputError


@dataclass(frozen=True)
class RepairReport:
    """What loading changed in the elevations.

    ``voids_filled``: cells without data (nodata, NaN) that were interpolated.
    ``spikes_repaired``: cells with impossible values (e.g. 32767) or far above
    or below all their neighbours, replaced by interpolation.
    """

    voids_filled: int = 0
    spikes_repaired: int = 0
    notes: tuple[str, ...] = ()
    invented: int = 0  # of the voids, cells over repair.FAR_VOID_CELLS from any data (a missing tile, nodata outside an outline)


@dataclass(frozen=True, eq=False)
class DEM:
    """Elevation grid with its geo-reference.

    Attributes
    ----------
    elevation : (rows, cols) float64 array, metres; row 0 is the north edge.
    transform : affine.Affine, north-up, maps (col, row) -> (x, y) of cell corners.
    crs : ``"EPSG:nnnn"`` (or a WKT string) of the world frame; None for a local
        metric frame with no geo-reference (lat/lon then unavailable).
    name : where the DEM came from, for messages.
    repair : what loading repaired.
    invented : (rows, cols) bool, True where loading invented the terrain (void cells far from any
        data: ``RepairReport.invented``), or None where nothing was; not part of the fingerprint.
    """

    elevation: np.ndarray
    transform: Affine
    crs: str | None
    name: str = ""
    repair: RepairReport = field(default_factory=RepairReport)
    invented: np.ndarray | None = None

    def __post_init__(self) -> None:
        z = self.elevation
        if z.ndim != 2 or min(z.shape) < 2:
            raise InputError(f"{self.name or 'DEM'}: needs at least 2 x 2 cells, got shape {z.shape}")
        if not np.all(np.isfinite(z)):
            raise InputError(f"{self.name or 'DEM'}: elevations contain NaN or infinity")
        t = self.transform
        if t.b != 0 or t.d != 0 or t.a <= 0 or t.e >= 0:
            raise InputError(f"{self.name or 'DEM'}: only north-up grids are supported (transform {tuple(t)[:6]})")
        if self.invented is not None and self.invented.shape != z.shape:
            raise ValueError(f"invented mask {self.invented.shape} does not match the grid {z.shape}")

    # --- grid geometry -------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return self.elevation.shape  # type: ignore[return-value]

    @property
    def cell_size(self) -> tuple[float, float]:
        """(dx, dy) cell size in metres, both positive."""
        return float(self.transform.a), float(-self.transform.e)

    @property
    def x_centres(self) -> np.ndarray:
        """x of cell centres, west to east, shape (cols,)."""
        return self.transform.c + (np.arange(self.shape[1]) + 0.5) * self.transform.a

    @property
    def y_centres(self) -> np.ndarray:
        """y of cell centres, north to south (row order), shape (rows,)."""
        return self.transform.f + (np.arange(self.shape[0]) + 0.5) * self.transform.e

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the outer cell *centres*: where the surface is defined."""
        xc, yc = self.x_centres, self.y_centres
        return float(xc[0]), float(xc[-1]), float(yc[-1]), float(yc[0])

    @property
    def centre(self) -> tuple[float, float]:
        """(x, y) of the middle of the defined surface."""
        xmin, xmax, ymin, ymax = self.extent
        return 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)

    def fractional_index(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """(col, row) as continuous indices of cell centres: centre (0, 0) -> (0.0, 0.0)."""
        dx, dy = self.cell_size
        xmin, _, _, ymax = self.extent
        return (np.asarray(x, float) - xmin) / dx, (ymax - np.asarray(y, float)) / dy

    def contains(self, x, y) -> np.ndarray:
        """True where (x, y) lies on the defined surface (between outer cell centres)."""
        return self._on_surface(*self.fractional_index(x, y))

    def _on_surface(self, col, row) -> np.ndarray:
        """:meth:`contains` on fractional indices (NaN compares False: off the surface)."""
        rows, cols = self.shape
        return (col >= 0) & (col <= cols - 1) & (row >= 0) & (row <= rows - 1)

    def is_invented(self, x, y) -> np.ndarray:
        """True where the cell holding world point (x, y) is invented terrain (:attr:`invented`);
        False outside the grid and where nothing was invented."""
        x, y = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(y, np.float64))
        if self.invented is None:
            return np.zeros(x.shape, bool)
        col, row = (np.rint(v).astype(np.int64) for v in self.fractional_index(x, y))  # the nearest cell centre
        inside = (row >= 0) & (row < self.shape[0]) & (col >= 0) & (col < self.shape[1])
        out = np.zeros(x.shape, bool)
        out[inside] = self.invented[row[inside], col[inside]]
        return out

    def ground(self, x, y) -> np.ndarray:
        """Height g(x, y) of the terrain surface in metres; NaN outside the DEM.

        Vectorized over any broadcastable x, y. Exact on the triangle mesh of
        the README's Conventions (quads split south-west to north-east).
        """
        col, row = self.fractional_index(x, y)
        col, row = np.broadcast_arrays(col, row)
        rows, cols = self.shape
        inside = self._on_surface(col, row)
        col, row = np.where(inside, col, 0), np.where(inside, row, 0)
        c = np.clip(np.floor(col).astype(np.int64), 0, cols - 2)
        r = np.clip(np.floor(row).astype(np.int64), 0, rows - 2)
        s = col - c  # east fraction from the SW corner
        t = 1.0 - (row - r)  # north fraction from the SW corner
        z = self.elevation
        z_nw, z_ne = z[r, c], z[r, c + 1]
        z_sw, z_se = z[r + 1, c], z[r + 1, c + 1]
        lower = z_sw + s * (z_se - z_sw) + t * (z_ne - z_se)  # triangle SW, SE, NE
        upper = z_sw + t * (z_nw - z_sw) + s * (z_ne - z_nw)  # triangle SW, NE, NW
        out = np.where(s >= t, lower, upper)
        return np.where(inside, out, np.nan)

    def slope_deg(self, x, y) -> np.ndarray:
        """Slope (deg from level) of the ground at (x, y), from central differences of
        :meth:`ground` one cell either side along x and along y; NaN where those lie off
        the DEM. Vectorized like :meth:`ground`."""
        dx, dy = self.cell_size
        x, y = np.asarray(x, float), np.asarray(y, float)
        gx = (self.ground(x + dx, y) - self.ground(x - dx, y)) / (2 * dx)
        gy = (self.ground(x, y + dy) - self.ground(x, y - dy)) / (2 * dy)
        return np.degrees(np.arctan(np.hypot(gx, gy)))

    # --- geo-reference ---------------------------------------------------------
    @cached_property
    def _to_lonlat(self):
        from pyproj import Transformer

        if self.crs is None:
            raise InputError(f"{self.name or 'DEM'} has no CRS: lat/lon are unavailable (give --crs)")
        return Transformer.from_crs(self.crs, "EPSG:4326", always_xy=True)

    @cached_property
    def _from_lonlat(self):
        from pyproj import Transformer

        if self.crs is None:
            raise InputError(f"{self.name or 'DEM'} has no CRS: lat/lon are unavailable (give --crs)")
        return Transformer.from_crs("EPSG:4326", self.crs, always_xy=True)

    def to_lonlat(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) -> (lon, lat) in degrees, WGS 84."""
        return self._to_lonlat.transform(np.asarray(x, float), np.asarray(y, float))

    def from_lonlat(self, lon, lat) -> tuple[np.ndarray, np.ndarray]:
        """(lon, lat) in degrees, WGS 84 -> world (x, y)."""
        return self._from_lonlat.transform(np.asarray(lon, float), np.asarray(lat, float))

    def camera_pose(self, x: float, y: float, height: float, pan: float, tilt: float, swing: float):
        """The :class:`~skyrender.camera.Pose` of a camera ``height`` metres above the
        ground at (x, y), z = g(x, y) + height; InputError outside the DEM."""
        from ..camera import Pose

        for name, value in (("x", x), ("y", y), ("height", height), ("pan", pan), ("tilt", tilt), ("swing", swing)):
            if not np.isfinite(value):
                raise InputError(f"{name} must be a finite number, got {value}")
        if height < 0:
            raise InputError(f"camera height above ground must be >= 0 m, got {height}")
        if not -90.0 <= tilt <= 90.0:
            raise InputError(f"tilt must lie in [-90, 90] degrees, got {tilt}")
        if not bool(self.contains(x, y)):
            xmin, xmax, ymin, ymax = self.extent
            raise InputError(
                f"camera position ({x:.1f}, {y:.1f}) lies outside the DEM "
                f"(x {xmin:.1f} .. {xmax:.1f}, y {ymin:.1f} .. {ymax:.1f}, {self.crs or 'local frame'})"
            )
        return Pose(x, y, float(self.ground(x, y)) + height, pan, tilt, swing).normalized()

    def coarsened(self, factor: int) -> "DEM":
        """The DEM averaged over ``factor`` x ``factor`` blocks of cells (a coarser source of
        the same terrain, e.g. 30 m -> 90 m for ``factor`` 3); rows and columns that do not
        fill a block are dropped. ``factor`` 1 returns the DEM itself."""
        factor = int(factor)
        if factor < 1:
            raise InputError(f"block factor must be >= 1, got {factor}")
        if factor == 1:
            return self
        rows, cols = (n // factor for n in self.shape)
        if min(rows, cols) < 2:
            raise InputError(f"{self.name or 'DEM'}: too small for {factor} x {factor} blocks")
        z = self.elevation[: rows * factor, : cols * factor].reshape(rows, factor, cols, factor).mean(axis=(1, 3))
        invented = None if self.invented is None else (
            self.invented[: rows * factor, : cols * factor].reshape(rows, factor, cols, factor).mean(axis=(1, 3)) > 0.5)
        return DEM(z, self.transform @ Affine.scale(factor), self.crs, f"{self.name} ({factor}x{factor} block mean)",
                   invented=invented)

    def fingerprint(self) -> str:
        """Stable hash of elevations, grid and CRS (to refuse mismatched models)."""
        h = hashlib.sha256()
        h.update(np.ascontiguousarray(self.elevation, dtype=np.float64).tobytes())
        h.update(repr(tuple(round(v, 9) for v in tuple(self.transform)[:6])).encode())
        h.update(str(self.crs).encode())
        return h.hexdigest()[:16]

    def describe(self) -> str:
        rows, cols = self.shape
        dx, dy = self.cell_size
        z = self.elevation
        return (
            f"{self.name}: {cols} x {rows} cells of {dx:g} x {dy:g} m, {self.crs or 'local frame'}, "
            f"elevation {z.min():.0f} .. {z.max():.0f} m; voids filled {self.repair.voids_filled}, "
            f"spikes repaired {self.repair.spikes_repaired}"
        )
