"""Loading DEMs from the files users have.

Readers: GeoTIFF, SRTM ``.hgt`` and ESRI ASCII grids through rasterio;
``.npy``/``.npz`` arrays with an explicit cell size; the built-in real DEM
(matplotlib's Jacksboro fault, ``builtin:jacksboro``). A DEM in a geographic
CRS is reprojected once, on load, to the WGS 84 / UTM zone holding its
centre (README, Conventions), onto the largest axis-aligned grid lying inside the
source tile, so no cell of the result is invented beyond the data.
"""

from __future__ import annotations

import math
import os
from dataclasses import replace

import numpy as np
from affine import Affine

from ..errors import InputError
from .grid import DEM, RepairReport
from .repair import repair_elevation

#: builtin:jacksboro is matplotlib's real DEM; builtin:naval2000 the paper-like synthetic
#: scene (600 x 600 cells of 50 m, two dominant mountains; :func:`.synthetic.fractal_terrain`).
BUILTIN_DEMS = ("builtin:jacksboro", "builtin:naval2000")
EARTH_METRES_PER_DEGREE = 111_320.0


def utm_epsg(lon: float, lat: float) -> int:
    """EPSG code of the WGS 84 / UTM zone holding (lon, lat): 326zz north, 327zz south."""
    zone = int(math.floor((lon + 180.0) / 6.0)) % 60 + 1
    return (32600 if lat >= 0 else 32700) + zone


def _crs_string(crs) -> str | None:
    """Normalise any CRS description to 'EPSG:nnnn' where possible."""
    if crs is None:
        return None
    from pyproj import CRS

    try:
        c = CRS.from_user_input(crs)
    except Exception as exc:
        raise InputError(f"unknown CRS {crs!r}: {exc}") from None
    epsg = c.to_epsg()
    return f"EPSG:{epsg}" if epsg else c.to_wkt()


RASTER_SUFFIXES = (".hgt", ".tif", ".tiff", ".asc", ".vrt")


def load_dem(path: str | os.PathLike | list | tuple | None = None, *, crs=None, cell_size: float | None = None,
             resolution: float | None = None, bounds: tuple[float, float, float, float] | None = None) -> DEM:
    """Read a DEM into the world frame of the README's Conventions, voids filled and spikes repaired.

    Parameters
    ----------
    path : file path, or ``builtin:jacksboro`` / None for the built-in real DEM
        (``builtin:naval2000``: the paper-like synthetic scene). Several
        tiles are mosaicked into one DEM: give a list of paths, paths joined by commas,
        a directory (every ``.hgt``/``.tif`` in it) or a GDAL VRT.
    crs : CRS of the file when it has none (e.g. ``EPSG:31254`` for an ESRI grid),
        or of a ``.npy``/``.npz`` array. Without one, such DEMs use a local frame.
    cell_size : metres per cell, required for ``.npy`` (and ``.npz`` without one).
    resolution : cell size in metres after reprojecting a geographic DEM
        (default: the geometric mean of the source cell's sides, to 1 m).
    bounds : (west, south, east, north) in the raster files' CRS (degrees for SRTM):
        read only that window of the tiles (a search area inside a large mosaic).
    """
    if str(path) == "builtin:naval2000":
        from .synthetic import fractal_terrain

        return replace(fractal_terrain(), name="builtin:naval2000")
    if path is None or str(path) in BUILTIN_DEMS:
        return _load_jacksboro(resolution)
    tiles = dem_tiles(path)
    if len(tiles) > 1 or bounds is not None:
        folder = not isinstance(path, (list, tuple)) and os.path.isdir(os.fspath(path))
        return _load_mosaic(tiles, crs=crs, resolution=resolution, bounds=bounds, from_folder=folder)
    path = tiles[0]
    ext = os.path.splitext(path)[1].lower()
    if ext in (".npy", ".npz"):
        return _load_array(path, crs=crs, cell_size=cell_size)
    return _load_raster(path, crs=crs, resolution=resolution)


def dem_tiles(path) -> list[str]:
    """The DEM files a ``--dem`` value names: one file, several (a list or commas), or the
    rasters of a directory (sorted); InputError where one is missing or none is found."""
    if isinstance(path, (list, tuple)):
        parts = [os.fspath(p) for p in path]
    else:
        text = os.fspath(path)
        parts = [p.strip() for p in text.split(",") if p.strip()] if "," in text and not os.path.exists(text) else [text]
    if len(parts) == 1 and os.path.isdir(parts[0]):
        folder = parts[0]
        parts = sorted(os.path.join(folder, f) for f in os.listdir(folder)
                       if f.lower().endswith(RASTER_SUFFIXES) and not f.lower().endswith(".vrt"))
        if not parts:
            raise InputError(f"DEM directory holds no .hgt/.tif/.asc files: {folder}")
    if not parts:
        raise InputError("no DEM given")
    for p in parts:
        if not os.path.exists(p):
            raise InputError(f"DEM file not found: {p}")
        if os.path.isdir(p):
            raise InputError(f"DEM path is a directory, not a file: {p}")
    return parts


#: The most cells a mosaic may have (a 3 x 3 block of 1-arc-second tiles has 117 M): more is refused before it is
#: read, naming its size, instead of exhausting memory (SRTM tiles from two continents would make billions).
MAX_MOSAIC_CELLS = 150_000_000


class SkippedTilesWarning(UserWarning):
    """Tiles of a DEM directory left out of its mosaic (another CRS or cell size than most of the tiles that
    reach the window); the command line prints it as a warning."""


def _covered_area(src_bounds, window) -> float:
    """The area of a (west, south, east, north) window a raster's bounds cover (the same CRS; 0: the raster does not
    reach into it); 1 without a window, so that kinds of tiles are then compared by their counts."""
    if window is None:
        return 1.0
    return (max(0.0, min(src_bounds.right, window[2]) - max(src_bounds.left, window[0]))
            * max(0.0, min(src_bounds.top, window[3]) - max(src_bounds.bottom, window[1])))


def _grid_kind(src) -> tuple[str, tuple[float, float]]:
    """(CRS, cell size) of an open raster: the tiles of one mosaic must share both."""
    return str(src.crs), tuple(round(abs(r), 12) for r in src.res)


def _snap_window(window, transform: Affine) -> tuple[float, float, float, float]:
    """A (west, south, east, north) window grown to whole cells of a north-up grid (``transform``: a tile's), so
    that a merge reads the tiles' own posts: rasterio.merge starts its grid at the window's corner, and from a
    corner between posts every cell takes the nearest post, up to half a cell away (32 m east, 46 m north for
    SRTM3 in the Alps), rounding one tile one way and its neighbour the other."""
    x0, y0, rx, ry = transform.c, transform.f, transform.a, -transform.e
    eps = 1e-6  # of a cell: a window already on the grid stays where it is
    return (x0 + math.floor((window[0] - x0) / rx + eps) * rx, y0 - math.ceil((y0 - window[1]) / ry - eps) * ry,
            x0 + math.ceil((window[2] - x0) / rx - eps) * rx, y0 - math.floor((y0 - window[3]) / ry + eps) * ry)


def _tiles_to_merge(sources: list, paths: list[str], bounds, from_folder: bool, name: str) -> list[int]:
    """The indices of the open rasters a mosaic is merged from. With a window, only the tiles reaching into it (a
    folder of tiles may hold far-away ones). Tiles of different CRSs or cell sizes cannot be merged: from a folder, the
    kind covering most of the window is kept (without a window: the kind of most tiles; ties: the first file's; a
    grid without a CRS only where no other reaches the window), the others named in a :class:`SkippedTilesWarning`;
    from tiles the user listed one by one, InputError."""
    import warnings

    reach = [_covered_area(src.bounds, bounds) for src in sources]
    keep = [i for i in range(len(sources)) if reach[i] > 0]
    if not keep:
        raise InputError(f"{name}: the window lies outside the tiles (no tile reaches into "
                         f"{', '.join(f'{b:g}' for b in bounds)})")
    kinds = [_grid_kind(sources[i]) for i in keep]
    if len(set(kinds)) > 1:
        if not from_folder:
            if len({k[0] for k in kinds}) > 1:
                raise InputError(f"{name}: the tiles are in different CRSs ({', '.join(sorted({k[0] for k in kinds}))})")
            raise InputError(f"{name}: the tiles have different cell sizes")
        # a grid without a CRS counts last: its coordinates are not in the window's units, whatever they overlap
        common = max(kinds, key=lambda kind: (kind[0] != "None", sum(reach[i] for i, k in zip(keep, kinds) if k == kind),
                                              kinds.count(kind)))
        left_out = [os.path.basename(paths[i]) for i, k in zip(keep, kinds) if k != common]
        keep = [i for i, k in zip(keep, kinds) if k == common]
        warnings.warn(f"left out of the mosaic, their CRS or cell size not that of the other {len(keep)} tiles: "
                      f"{', '.join(left_out)}", SkippedTilesWarning, stacklevel=2)
    return keep


def _load_mosaic(paths: list[str], *, crs, resolution: float | None, bounds=None, from_folder: bool = False) -> DEM:
    """Several raster tiles of one CRS merged into one grid (rasterio.merge), then loaded as
    one DEM. Adjacent SRTM tiles share their edge row/column: the shared posts coincide.
    ``from_folder``: the tiles are a directory's, which may hold other kinds (:func:`_tiles_to_merge`)."""
    import rasterio
    from rasterio.merge import merge

    def mosaic_name(names: list[str]) -> str:
        return ((f"mosaic of {len(names)} tiles ({os.path.basename(names[0])}, ...)" if len(names) > 1
                 else os.path.basename(names[0])) + (f" in {tuple(round(b, 4) for b in bounds)}" if bounds else ""))

    name = mosaic_name(paths)
    try:
        sources = [rasterio.open(p) for p in paths]
    except Exception as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{name}: a tile cannot be read ({first})") from None
    try:
        keep = _tiles_to_merge(sources, paths, bounds, from_folder, name)
        tiles = [sources[i] for i in keep]
        name = mosaic_name([paths[i] for i in keep])
        file_crs = tiles[0].crs
        nodata = tiles[0].nodata
        if bounds is not None:
            bounds = _snap_window(bounds, tiles[0].transform)
            west, south, east, north = bounds
        else:
            west, south = min(src.bounds.left for src in tiles), min(src.bounds.bottom for src in tiles)
            east, north = max(src.bounds.right for src in tiles), max(src.bounds.top for src in tiles)
        res_x, res_y = (abs(r) for r in tiles[0].res)
        cells = round((east - west) / res_x) * round((north - south) / res_y)
        if cells > MAX_MOSAIC_CELLS:
            raise InputError(f"{name}: the mosaic would have {cells:,} cells (at most {MAX_MOSAIC_CELLS:,}); give a "
                             "window (--dem-bounds) or fewer tiles")
        try:
            data, transform = merge(tiles, bounds=bounds, nodata=nodata if nodata is not None else -32768,
                                    masked=True)
        except Exception as exc:
            raise InputError(f"{name}: the tiles cannot be merged ({str(exc).splitlines()[0]})") from None
    finally:
        for src in sources:
            src.close()
    band = data[0]
    z = np.ma.getdata(band).astype(np.float64)
    void = np.ma.getmaskarray(band)
    crs_str = _crs_string(file_crs) if file_crs else _crs_string(crs)
    return _georeference(z, void, transform, crs_str, name, resolution)


def _load_raster(path: str, *, crs, resolution: float | None) -> DEM:
    import rasterio
    from rasterio.errors import RasterioError, RasterioIOError

    try:
        with rasterio.open(path) as src:
            if src.count < 1:
                raise InputError(f"{path}: raster has no bands")
            band = src.read(1, masked=True)
            transform = src.transform
            file_crs = src.crs
    except InputError:
        raise
    except MemoryError:
        raise InputError(f"{path}: the DEM is too large to read into memory") from None
    except (RasterioIOError, RasterioError, ValueError, OSError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{path}: not a DEM that can be read ({first})") from None
    if not np.issubdtype(band.dtype, np.number) or band.ndim != 2:
        raise InputError(f"{path}: not a numeric elevation grid")
    z = np.ma.getdata(band).astype(np.float64)
    nodata = np.ma.getmaskarray(band)
    crs_str = _crs_string(file_crs) if file_crs else _crs_string(crs)
    return _georeference(z, nodata, transform, crs_str, os.path.basename(path), resolution)


def _load_array(path: str, *, crs, cell_size: float | None) -> DEM:
    try:
        data = np.load(path, allow_pickle=False)
    except Exception as exc:
        raise InputError(f"{path}: not a readable numpy array ({str(exc).splitlines()[0]})") from None
    x0 = y0 = 0.0
    if isinstance(data, np.lib.npyio.NpzFile):
        keys = data.files
        key = "elevation" if "elevation" in keys else (keys[0] if keys else None)
        if key is None:
            raise InputError(f"{path}: empty .npz archive")
        try:  # members are read (and their CRCs and headers checked) only now
            z = data[key]
            if cell_size is None and "cell_size" in keys:
                cell_size = float(data["cell_size"])
            x0 = float(data["x_origin"]) if "x_origin" in keys else 0.0
            y0 = float(data["y_origin"]) if "y_origin" in keys else None
            if crs is None and "crs" in keys:
                crs = str(data["crs"])
        except MemoryError:
            raise InputError(f"{path}: the array does not fit in memory") from None
        except Exception as exc:  # BadZipFile, a garbled .npy header, zlib errors, ...: a damaged archive
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputError(f"{path}: damaged .npz archive ({reason[:100]})") from None
    else:
        z, y0 = data, None
    if not np.issubdtype(np.asarray(z).dtype, np.number) or np.ndim(z) != 2:
        raise InputError(f"{path}: expected a 2-D numeric elevation array, got shape {np.shape(z)}")
    if cell_size is None or not (cell_size > 0 and math.isfinite(cell_size)):
        raise InputError(f"{path}: a numpy DEM needs a positive cell size (--cell-size METRES)")
    z = np.asarray(z, dtype=np.float64)
    if y0 is None:  # origin at the south-west corner of the grid
        y0 = z.shape[0] * cell_size
    transform = Affine(cell_size, 0.0, x0, 0.0, -cell_size, y0)
    return _georeference(z, ~np.isfinite(z), transform, _crs_string(crs), os.path.basename(path), None)


def _load_jacksboro(resolution: float | None) -> DEM:
    """matplotlib's real 3-arc-second DEM of the Jacksboro fault, Tennessee.

    Its rows run north to south; its ``ymin`` key holds the *northern* edge
    (the keys are swapped) and the x/y keys are the outer edges of the grid.
    """
    from matplotlib import cbook

    d = cbook.get_sample_data("jacksboro_fault_dem.npz")
    z = d["elevation"].astype(np.float64)
    north = max(float(d["ymin"]), float(d["ymax"]))
    west = float(d["xmin"])
    transform = Affine(float(d["dx"]), 0.0, west, 0.0, -float(d["dy"]), north)
    return _georeference(z, np.zeros(z.shape, bool), transform, "EPSG:4326", "builtin:jacksboro", resolution)


def _georeference(z, nodata, transform: Affine, crs: str | None, name: str, resolution: float | None) -> DEM:
    """Repair the grid, then reproject it to UTM if its CRS is geographic."""
    if z.ndim != 2 or min(z.shape) < 2:
        raise InputError(f"{name}: a DEM needs at least 2 x 2 cells, got shape {z.shape}")
    geographic = False
    if crs is not None:
        from pyproj import CRS

        geographic = CRS.from_user_input(crs).is_geographic
    if transform.b != 0 or transform.d != 0:
        raise InputError(f"{name}: rotated grids are not supported")
    if transform.e > 0:  # rows run south to north: flip to north-up
        z, nodata = z[::-1], nodata[::-1]
        transform = Affine(transform.a, 0, transform.c, 0, -transform.e, transform.f + transform.e * z.shape[0])
    if geographic:
        lat_mid = transform.f + transform.e * z.shape[0] / 2
        cell_m = math.sqrt(abs(transform.a) * math.cos(math.radians(lat_mid)) * abs(transform.e)) * EARTH_METRES_PER_DEGREE
    else:
        cell_m = math.sqrt(abs(transform.a * transform.e))
    fixed, report, invented = repair_elevation(z, cell_m, nodata)
    if not geographic:
        return DEM(fixed, transform, crs, name, report, invented)
    return _reproject_to_utm(fixed, transform, crs, name, report, resolution, invented)


def _reproject_to_utm(z, transform: Affine, crs: str, name: str, report: RepairReport, resolution: float | None,
                      invented: np.ndarray | None = None) -> DEM:
    from pyproj import Transformer
    from rasterio.warp import Resampling, reproject

    rows, cols = z.shape
    lon_c, lat_c = transform @ (cols / 2, rows / 2)
    dst_crs = f"EPSG:{utm_epsg(lon_c, lat_c)}"
    to_utm = Transformer.from_crs(crs, dst_crs, always_xy=True)
    if resolution is None:
        dx_m = abs(transform.a) * math.cos(math.radians(lat_c)) * EARTH_METRES_PER_DEGREE
        dy_m = abs(transform.e) * EARTH_METRES_PER_DEGREE
        resolution = float(max(1.0, round(math.sqrt(dx_m * dy_m))))
    # Inscribed rectangle: the tile's edges, densely sampled, bound the valid area.
    # Inset by half a source cell: beyond the outer cell centres there is no data.
    s = np.linspace(0.5, 0.5 + (max(rows, cols) - 1), 200)
    sc, sr = np.clip(s, 0.5, cols - 0.5), np.clip(s, 0.5, rows - 0.5)
    edges = {
        "west": (np.full_like(sr, 0.5), sr), "east": (np.full_like(sr, cols - 0.5), sr),
        "north": (sc, np.full_like(sc, 0.5)), "south": (sc, np.full_like(sc, rows - 0.5)),
    }
    xy = {k: to_utm.transform(*(transform @ (c, r))) for k, (c, r) in edges.items()}
    left, right = np.max(xy["west"][0]), np.min(xy["east"][0])
    bottom, top = np.max(xy["south"][1]), np.min(xy["north"][1])
    width, height = int((right - left) // resolution), int((top - bottom) // resolution)
    if width < 2 or height < 2:
        raise InputError(f"{name}: the DEM is too small to reproject to {dst_crs}")
    dst_transform = Affine(resolution, 0.0, float(left), 0.0, -resolution, float(top))
    dst = np.full((height, width), np.nan, dtype=np.float64)
    reproject(z, dst, src_transform=transform, src_crs=crs, dst_transform=dst_transform, dst_crs=dst_crs,
              resampling=Resampling.bilinear, src_nodata=np.nan, dst_nodata=np.nan)
    if invented is not None:  # onto the same grid, nearest cell
        mask = np.zeros((height, width), np.uint8)
        reproject(invented.astype(np.uint8), mask, src_transform=transform, src_crs=crs, dst_transform=dst_transform,
                  dst_crs=dst_crs, resampling=Resampling.nearest)
    rows_kept, cols_kept = _valid_window(dst)
    dst = np.ascontiguousarray(dst[rows_kept, cols_kept])
    invented = None if invented is None else mask[rows_kept, cols_kept] > 0
    return DEM(dst, dst_transform @ Affine.translation(cols_kept.start, rows_kept.start), dst_crs, name, report, invented)


def _valid_window(z: np.ndarray) -> tuple[slice, slice]:
    """(rows, cols) slices that drop the outer rows/columns holding NaN (resampling edge effects);
    InputError where cells without data remain inside."""
    r0, r1, c0, c1 = 0, z.shape[0], 0, z.shape[1]
    while r1 - r0 > 2 and c1 - c0 > 2:
        block = z[r0:r1, c0:c1]
        bad = [~np.isfinite(block[0]).all(), ~np.isfinite(block[-1]).all(),
               ~np.isfinite(block[:, 0]).all(), ~np.isfinite(block[:, -1]).all()]
        if not any(bad):
            break
        r0, r1, c0, c1 = r0 + bad[0], r1 - bad[1], c0 + bad[2], c1 - bad[3]
    if not np.isfinite(z[r0:r1, c0:c1]).all():
        raise InputError("reprojection left cells without data inside the grid")
    return slice(int(r0), int(r1)), slice(int(c0), int(c1))
