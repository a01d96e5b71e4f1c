"""The ``skyrender`` command line (README, Command line).

Every command prints a one-line error on stderr and exits with status 2 on
bad input; ``--json`` prints exactly one JSON object on stdout.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import time
import warnings
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from .errors import InputError

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Camera pose from one mountain photograph and a DEM.")

#: What a DEM argument may be (:func:`skyrender.dem.load_dem`)
DEM_HELP = ("DEM file (GeoTIFF, .hgt, .asc, .npy/.npz), several joined by commas, a directory of tiles (with "
            "--dem-bounds, those reaching the window), a VRT, or builtin:jacksboro")
DemOpt = typer.Option(..., "--dem", help=DEM_HELP)
CrsOpt = typer.Option(None, "--crs", help="CRS of a DEM file that has none, e.g. EPSG:31254")
CellOpt = typer.Option(None, "--cell-size", help="metres per cell, for .npy/.npz DEMs")
BoundsOpt = typer.Option(None, "--dem-bounds", help="W,S,E,N: read only this window of the DEM's raster files, in "
                         "their CRS (degrees for SRTM tiles): a photo's region of a large mosaic")
VariantOpt = typer.Option(None, "--variant", help="Mitsuba variant (default $SKYRENDER_VARIANT or llvm_ad_rgb)")


def parse_size(text: str) -> tuple[int, int]:
    """'640x480' -> (640, 480); InputError otherwise."""
    try:
        w, h = (int(p) for p in text.lower().split("x"))
    except ValueError:
        raise InputError(f"--size must look like WIDTHxHEIGHT (e.g. 640x480), got {text!r}") from None
    if not (2 <= w <= 16384 and 2 <= h <= 16384):
        raise InputError(f"--size must be between 2x2 and 16384x16384, got {text!r}")
    return w, h


def emit_json(obj: dict) -> None:
    sys.stdout.write(json.dumps(obj) + "\n")


@app.command()
def render(
    dem: str = DemOpt,
    x: Optional[float] = typer.Option(None, "--x", help="camera easting in the world frame (m)"),
    y: Optional[float] = typer.Option(None, "--y", help="camera northing in the world frame (m)"),
    lat: Optional[float] = typer.Option(None, "--lat", help="camera latitude (deg), instead of --y"),
    lon: Optional[float] = typer.Option(None, "--lon", help="camera longitude (deg), instead of --x"),
    height: float = typer.Option(..., "--height", help="camera height above ground (m)"),
    pan: float = typer.Option(..., "--pan", help="heading, degrees clockwise from grid north"),
    tilt: float = typer.Option(..., "--tilt", help="elevation of the optical axis, degrees"),
    swing: float = typer.Option(..., "--swing", help="roll about the optical axis, degrees"),
    fov: float = typer.Option(..., "--fov", help="horizontal field of view, degrees"),
    size: str = typer.Option(..., "--size", help="WIDTHxHEIGHT in pixels"),
    out: Path = typer.Option(..., "--out", help="output image (.png, .jpg)"),
    skyline_out: Optional[Path] = typer.Option(None, "--skyline-out", help="write the skyline (.npy or .json)"),
    overlay: Optional[Path] = typer.Option(None, "--overlay", help="also write the image with its skyline drawn"),
    flat_earth: bool = typer.Option(False, "--flat-earth", help="no earth curvature or refraction"),
    json_out: bool = typer.Option(False, "--json", help="print the pose as one JSON object"),
    crs: Optional[str] = CrsOpt,
    cell_size: Optional[float] = CellOpt,
    dem_bounds: Optional[str] = BoundsOpt,
    sun_azimuth: float = typer.Option(135.0, help="sun azimuth, degrees clockwise from north"),
    sun_elevation: float = typer.Option(35.0, help="sun elevation, degrees"),
    haze: float = typer.Option(40_000.0, help="aerial-perspective e-folding distance (m)"),
    noise: float = typer.Option(0.0, help="sensor noise std, 0..1"),
    occluders: float = typer.Option(0.0, help="share of columns covered by foreground trees/posts, 0..1"),
    supersample: int = typer.Option(2, help="samples per pixel side (anti-aliasing)"),
    seed: int = typer.Option(0, help="seed for texture, noise and occluders"),
    sky: str = typer.Option("clear", help="sky type: clear, hazy, overcast, sunset"),
    clouds: float = typer.Option(0.0, help="cover of cloud banks resting on the ridges, 0..1"),
    power_lines: int = typer.Option(0, help="cables sagging across the frame (count as sky)"),
    variant: Optional[str] = VariantOpt,
):
    """Render a realistic photograph of the terrain from a pose."""
    from .camera import Intrinsics
    from .io import save_skyline
    from .render import Terrain
    from .render.photo import Look, render_photo
    from .viz import draw_skyline, write_image

    width, height_px = parse_size(size)
    intrinsics = Intrinsics.from_fov(fov, width, height_px)
    from .render.photo import SKY_TYPES

    if sky not in SKY_TYPES:
        raise InputError(f"--sky must be one of {', '.join(SKY_TYPES)}, got {sky!r}")
    for name, value, lo, hi in (("--noise", noise, 0, 1), ("--occluders", occluders, 0, 1),
                                ("--clouds", clouds, 0, 1), ("--power-lines", power_lines, 0, 50),
                                ("--seed", seed, 0, 2**32 - 1),
                                ("--supersample", supersample, 1, 8), ("--haze", haze, 1e-6, float("inf"))):
        if not lo <= value <= hi:
            raise InputError(f"{name} must lie in [{lo}, {hi}], got {value}")
    _check_writable(out, "--out", IMAGE_SUFFIXES)
    if overlay is not None:
        _check_writable(overlay, "--overlay", IMAGE_SUFFIXES)
    if skyline_out is not None:
        _check_writable(skyline_out, "--skyline-out", SKYLINE_SUFFIXES)
    terrain_dem = _load_dem(dem, crs, cell_size, dem_bounds)
    if (lat is None) != (lon is None) or (lat is not None and (x is not None or y is not None)):
        raise InputError("give the position as --x and --y, or as --lat and --lon")
    if lat is not None:
        x, y = (float(v) for v in terrain_dem.from_lonlat(lon, lat))
    if x is None or y is None:
        raise InputError("missing camera position: give --x and --y (or --lat and --lon)")
    pose = terrain_dem.camera_pose(x, y, height, pan, tilt, swing)
    terrain = Terrain(terrain_dem, curvature=not flat_earth, variant=variant)
    look = Look(sun_azimuth=sun_azimuth, sun_elevation=sun_elevation, haze_distance=haze, noise=noise,
                occluders=occluders, supersample=supersample, seed=seed, sky=sky, clouds=clouds,
                power_lines=power_lines)
    photo = render_photo(terrain, pose, intrinsics, look)
    write_image(out, photo.image)
    if overlay is not None:
        write_image(overlay, draw_skyline(photo.image, photo.skyline))
    if skyline_out is not None:
        save_skyline(skyline_out, photo.skyline)
    result = {"x": pose.x, "y": pose.y, "z": pose.z, "pan": pose.pan, "tilt": pose.tilt, "swing": pose.swing,
              "fov": intrinsics.fov, "width": width, "height": height_px, "crs": terrain_dem.crs}
    if json_out:
        emit_json(result)
    else:
        typer.echo(f"rendered {out} ({width}x{height_px}) from x={pose.x:.1f} y={pose.y:.1f} z={pose.z:.1f} "
                   f"pan={pose.pan:.2f} tilt={pose.tilt:.2f} swing={pose.swing:.2f} fov={intrinsics.fov:.2f}")


@app.command()
def skyline(
    image: Path = typer.Argument(..., help="photograph (PNG, JPEG, ...; gray, RGB, RGBA, 8/16-bit)"),
    out: Optional[Path] = typer.Option(None, "--out", help="write the skyline (.npy or .json)"),
    overlay: Optional[Path] = typer.Option(None, "--overlay", help="write the photo with the skyline drawn"),
    peaks: int = typer.Option(6, "--peaks", help="skyline peaks to report (with --json)"),
    json_out: bool = typer.Option(False, "--json", help="print {width, height, skyline} as one JSON object"),
    mask_out: Optional[Path] = typer.Option(None, "--mask-out", help="write the sky mask (PNG, white = sky): to "
                                            "correct by hand where the skyline is wrong and give to 'localize --sky-mask'"),
    method: str = typer.Option("auto", "--method", help="hybrid (learned + per-photo colour mixtures), net (learned), "
                               "gmm (per-photo colour mixtures), select (hybrid and gmm, the one more confident "
                               "where they part) or auto: select for camera photos (JPEG or camera EXIF), gmm for "
                               "others (renders)"),
):
    """Extract the skyline (sky/terrain boundary per column) from a photograph."""
    from .features import SkylineParams, extract_skyline, load_photo, sky_mask_of_skyline, skyline_peaks
    from .features.photo_io import is_camera_photo
    from .io import save_skyline, skyline_to_list
    from .viz import draw_skyline, write_image

    if peaks < 0:
        raise InputError(f"--peaks must be >= 0, got {peaks}")
    if method not in ("auto", "select", "hybrid", "net", "gmm"):
        raise InputError(f"--method must be auto, select, hybrid, net or gmm, got {method!r}")
    for path, option, kinds in ((out, "--out", SKYLINE_SUFFIXES), (overlay, "--overlay", IMAGE_SUFFIXES),
                                (mask_out, "--mask-out", (".png",))):
        if path is not None:
            _check_writable(path, option, kinds)
    photo = load_photo(image)
    if method == "auto":
        method = "select" if is_camera_photo(str(image)) else "gmm"
    result = extract_skyline(photo, SkylineParams(method=method))
    if out is not None:
        save_skyline(out, result.skyline)
    if overlay is not None:
        write_image(overlay, draw_skyline(photo, result.skyline))
    H, W = photo.shape[:2]
    if mask_out is not None:
        write_image(mask_out, np.where(sky_mask_of_skyline(result.skyline, H), 255, 0).astype(np.uint8))
    found = skyline_peaks(result.skyline, n=peaks)
    if json_out:
        emit_json({"width": W, "height": H, "skyline": skyline_to_list(result.skyline),
                   "confidence": [round(float(c), 4) for c in result.confidence],
                   "peaks": [{"u": p.u, "v": p.v, "size": p.size, "width": p.width} for p in found]})
    else:
        sky = result.skyline
        typer.echo(f"{image}: {W} x {H}; skyline in {int(np.isfinite(sky).sum())} of {W} columns, "
                   f"v {np.nanmin(sky) if np.isfinite(sky).any() else float('nan'):.1f} .. "
                   f"{np.nanmax(sky) if np.isfinite(sky).any() else float('nan'):.1f}; {len(found)} peaks"
                   + (f"; wrote {out}" if out else ""))


@app.command()
def model(
    dem: str = typer.Argument(..., help=DEM_HELP),
    out: Path = typer.Option(..., "--out", help="model directory to write"),
    major_radius: float = typer.Option(1800.0, help="a major peak is the highest within this radius (m)"),
    minor_radius: float = typer.Option(650.0, help="a minor peak is the highest within this radius (m)"),
    min_prominence: float = typer.Option(0.0, help="drop feature points less prominent than this (m)"),
    k: int = typer.Option(15, "--k", help="nearest feature points kept per pivot"),
    spacing: float = typer.Option(1000.0, help="co-visibility viewpoint grid spacing (m)"),
    camera_height: float = typer.Option(2.0, help="camera height above ground for co-visibility (m)"),
    max_range: float = typer.Option(40_000.0, help="farthest feature counted from a viewpoint (m)"),
    progress: bool = typer.Option(True, help="show a progress bar on stderr"),
    json_out: bool = typer.Option(False, "--json", help="print the summary as one JSON object"),
    crs: Optional[str] = CrsOpt,
    cell_size: Optional[float] = CellOpt,
    dem_bounds: Optional[str] = BoundsOpt,
    variant: Optional[str] = VariantOpt,
):
    """Build the model databases of a DEM (peaks, neighbour sets, co-visibility)."""
    from .backend import mitsuba
    from .model import CovisibilityParams, HorizonParams, ModelParams, PeakParams, build_model, save_model

    for name, value in (("--major-radius", major_radius), ("--minor-radius", minor_radius), ("--spacing", spacing),
                        ("--max-range", max_range)):
        if not value > 0:
            raise InputError(f"{name} must be positive, got {value}")
    if minor_radius > major_radius:
        raise InputError("--minor-radius must not exceed --major-radius")
    if camera_height < 0 or min_prominence < 0:
        raise InputError("--camera-height and --min-prominence must be >= 0")
    if k < 2:
        raise InputError(f"--k must be at least 2 (a pivot and two neighbours make a triple), got {k}")
    created = not out.exists()
    _check_model_dir(out)
    try:
        mitsuba(variant)
        t0 = time.perf_counter()
        terrain_dem = _load_dem(dem, crs, cell_size, dem_bounds)
        params = ModelParams(PeakParams(major_radius, minor_radius, min_prominence), k,
                             CovisibilityParams(spacing, camera_height, max_range), HorizonParams(height=camera_height))
        built = build_model(terrain_dem, params, progress=progress and not json_out)
        save_model(built, out)
    except BaseException:
        if created:  # a failed build leaves nothing behind
            shutil.rmtree(out, ignore_errors=True)
        raise
    seconds = time.perf_counter() - t0
    rows, cols = terrain_dem.shape
    if json_out:
        emit_json({"model": str(out), "features": len(built.features), "major": int(built.features.major.sum()),
                   "k": k, "viewpoints": built.covisibility.n_viewpoints, "rows": rows, "cols": cols,
                   "cell_size": terrain_dem.cell_size[0], "crs": terrain_dem.crs, "seconds": seconds,
                   "stage_seconds": built.stage_seconds})
    else:
        typer.echo(built.summary())
        typer.echo(f"wrote {out} in {seconds:.1f} s (DEM load included)")


@app.command()
def localize(
    image: Path = typer.Argument(..., help="photograph (PNG, JPEG, ...)"),
    model_dir: Optional[Path] = typer.Option(None, "--model", help="model directory from 'skyrender model'"),
    dem: Optional[str] = typer.Option(None, "--dem", help="DEM instead of a model: the model is built (and cached)"),
    height: float = typer.Option(..., "--height", help="camera height above ground (m)"),
    fov: Optional[float] = typer.Option(None, "--fov", help="horizontal field of view (deg); omitted: from the "
                                        "photo's EXIF focal length (used as given), else unknown"),
    json_out: bool = typer.Option(False, "--json", help="print the result as one JSON object"),
    overlay: Optional[Path] = typer.Option(None, "--overlay", help="write the photo with both skylines and peaks"),
    geojson: Optional[Path] = typer.Option(None, "--geojson", help="write the camera position and view cone"),
    candidates: int = typer.Option(0, "--candidates", help="also list the N best distinct places refined, the answer's "
                                   "(given or withheld) first: where to look when it abstains or doubts"),
    peaks: bool = typer.Option(False, "--peaks-in-view", help="also list the DEM's peaks on the skyline seen from the "
                               "answer: which summits the photo shows, where they are and how far"),
    skyline_file: Optional[Path] = typer.Option(None, "--skyline", help="the photo's skyline as you give it, instead of "
                                                "the extracted one: .npy or .json as 'skyrender skyline --out' writes "
                                                "it (corrected by hand, say)"),
    sky_mask: Optional[Path] = typer.Option(None, "--sky-mask", help="a mask of the photo's size, white where it shows "
                                            "sky: its skyline instead of the extracted one"),
    terrain_mask: Optional[Path] = typer.Option(None, "--terrain-mask", help="as --sky-mask, but white where it shows "
                                                "terrain (the CH1 and GeoPose3K masks' convention)"),
    stats: bool = typer.Option(False, "--stats", help="print per-stage times and hypothesis counts (stderr)"),
    prior_peak: Optional[list[int]] = typer.Option(None, "--prior-peak", help="id of a model peak known to be in view"),
    prior_near: Optional[str] = typer.Option(None, "--prior-near", help="X,Y,RADIUS: a peak within RADIUS m is in view"),
    unordered: bool = typer.Option(False, "--unordered", help="ignore the co-visibility ordering (for comparison)"),
    flat_earth: bool = typer.Option(False, "--flat-earth", help="no earth curvature or refraction"),
    preset: str = typer.Option("auto", "--preset", help="photo: a real photograph (a DEM that never matches "
                               "exactly); render: a view rendered from the DEM itself; auto: photo for JPEG "
                               "files or files with EXIF camera data, render otherwise"),
    crs: Optional[str] = CrsOpt,
    cell_size: Optional[float] = CellOpt,
    dem_bounds: Optional[str] = BoundsOpt,
    variant: Optional[str] = VariantOpt,
):
    """Estimate the camera pose (x, y, z, pan, tilt, swing) from one photograph.

    Exit status 0: localized; 3: abstained (no pose it would stand behind). With ``--candidates N``
    the best N distinct places it refined are listed too (``"candidates"`` in ``--json``, points in
    ``--geojson``), abstaining or not: only the first, the answer's, has a confidence. With ``--skyline``,
    ``--sky-mask`` or ``--terrain-mask`` the photo's skyline is yours, not extracted (every column trusted; the
    photo preset's confidence then is the one fitted for such skylines)."""
    from dataclasses import replace

    from .features import given_skyline, load_photo
    from .features.photo_io import exif_fov, is_camera_photo
    from .io import camera_geojson, write_json
    from .localizer import LocalizeParams
    from .localizer import localize as run_localize
    from .model import ModelParams
    from .render import Terrain
    from .viz import localization_overlay, write_image

    if (model_dir is None) == (dem is None):
        raise InputError("give exactly one of --model MODEL_DIR and --dem DEM")
    if not (np.isfinite(height) and 0 <= height <= MAX_HEIGHT_M):
        raise InputError(f"--height must lie in [0, {MAX_HEIGHT_M:.0f}] m above ground, got {height}")
    if fov is not None and not (0 < fov < 180):
        raise InputError(f"--fov must lie in (0, 180) degrees, got {fov}")
    if not 0 <= candidates <= MAX_CANDIDATES:
        raise InputError(f"--candidates must lie in [0, {MAX_CANDIDATES}], got {candidates}")
    for path, option, kinds in ((overlay, "--overlay", IMAGE_SUFFIXES), (geojson, "--geojson", (".geojson", ".json"))):
        if path is not None:
            _check_writable(path, option, kinds)
    if preset not in ("auto", "photo", "render"):
        raise InputError(f"--preset must be auto, photo or render, got {preset!r}")
    given_files = (skyline_file, sky_mask, terrain_mask)  # given_skyline's order
    if sum(p is not None for p in given_files) > 1:
        raise InputError("give at most one of --skyline, --sky-mask and --terrain-mask")
    prior = _parse_prior(prior_peak, prior_near)
    photo = load_photo(image)
    given = (given_skyline(photo.shape[1], photo.shape[0], *given_files)
             if any(p is not None for p in given_files) else None)
    from_exif = exif_fov(str(image)) if fov is None else None
    if preset == "auto":
        preset = "photo" if is_camera_photo(str(image)) else "render"
    the_model = _load_or_build_model(model_dir, dem, crs, cell_size, dem_bounds, variant,
                                     ModelParams.for_photos() if preset == "photo" else ModelParams(),
                                     progress=not json_out and sys.stderr.isatty())
    terrain = Terrain(the_model.dem, curvature=not flat_earth, variant=variant)
    base = LocalizeParams.for_photos() if preset == "photo" else LocalizeParams()
    # an EXIF fov is used as a given one: the mode the photo confidence is fitted and measured for (CH1's given focal
    # lengths are as rough: ~4 % short at one place); refitting it let wrong places fit it too (experiments/ch1/exif-fov/)
    params = replace(base, ordered=not unordered)
    if given is not None:
        params = params.for_given_skyline()
    fov = fov if from_exif is None else from_exif
    result = run_localize(photo, the_model, height, fov, prior, terrain=terrain, skyline=given, params=params,
                          curvature=not flat_earth)
    places = result.places(candidates, params.places_apart_m, the_model.dem)
    if overlay is not None:
        from .features import as_rgb8

        write_image(overlay, localization_overlay(as_rgb8(photo), result, the_model,
                                                  places=places_skylines(places, result, terrain)))
    if geojson is not None and (result.localized or places):
        doc = (camera_geojson(result.pose, result.fov, the_model.dem) if result.localized
               else {"type": "FeatureCollection", "features": []})
        doc["features"] += places_geojson(places)
        write_json(geojson, doc)
    if stats:
        st = result.stats.to_dict()
        print(f"stats: {json.dumps(st)}", file=sys.stderr)
    summits = result.peaks_in_view(the_model, curvature=not flat_earth) if peaks else []
    if json_out:
        emit_json({**result.to_json(), **({"candidates": places} if candidates else {}),
                   **({"peaks_in_view": summits} if peaks else {})})
        return 0 if result.localized else 3
    if result.localized:
        d = result.to_json()
        where = f" (lat {d['lat']:.5f}, lon {d['lon']:.5f})" if d["lat"] is not None else ""
        typer.echo(f"localized: x={d['x']:.1f} y={d['y']:.1f} z={d['z']:.1f}{where} pan={d['pan']:.2f} "
                   f"tilt={d['tilt']:.2f} swing={d['swing']:.2f} fov={d['fov']:.2f}; confidence "
                   f"{d['confidence']:.2f}{second_opinion_text(result.stats.second_opinion, True, params.second_opinion_m)}; "
                   f"{d['hypotheses']} hypotheses in {d['seconds']:.1f} s")
    else:
        # with the fov unknown the photo preset answers less often (a wrong focal length is one more freedom for a
        # wrong place: experiments/ch1/other-fov-runner-up/): say what would change that
        hint = ("; the field of view was unknown: give --fov (or a photo with an EXIF focal length)"
                if fov is None else "")
        second = second_opinion_text(result.stats.second_opinion, False, params.second_opinion_m)
        typer.echo(f"abstained: no pose found that fits the skyline well enough ({result.hypotheses} hypotheses, "
                   f"{result.seconds:.1f} s){second}{hint}")
    for line in places_text(places, result.localized):
        typer.echo(line)
    for line in peaks_text(summits):
        typer.echo(line)
    return 0 if result.localized else 3


def peaks_text(summits: list[dict]) -> list[str]:
    """``localize --peaks-in-view``'s lines (:meth:`LocalizationResult.peaks_in_view`), left to right in the photo."""
    if not summits:
        return []
    lines = [f"peaks in view, left to right ({len(summits)}):"]
    for p in summits:
        where = f"lat {p['lat']:.5f}, lon {p['lon']:.5f}" if p["lat"] is not None else f"x={p['x']:.0f} y={p['y']:.0f}"
        lines.append(f"  P{p['id']} {p['elevation_m']:.0f} m{' (major)' if p['major'] else ''}: {where}; "
                     f"{p['distance_m'] / 1000:.1f} km away, bearing {p['bearing_deg']:.0f} deg; "
                     f"in the photo at u={p['u']:.0f}, v={p['v']:.0f}")
    return lines


#: ``localize --candidates``: at most this many places listed (the photo preset refines 16 poses a search).
MAX_CANDIDATES = 50


def places_text(places: list[dict], localized: bool) -> list[str]:
    """A line per place of :meth:`~skyrender.localizer.LocalizationResult.places` for the text output."""
    lines = []
    for p in places:
        where = f"lat {p['lat']:.5f}, lon {p['lon']:.5f}" if p["lat"] is not None else f"x={p['x']:.1f} y={p['y']:.1f}"
        what = (f"the answer, confidence {p['confidence']:.2f}" if localized else
                f"the answer withheld, confidence {p['confidence']:.2f}") if p["rank"] == 1 else \
            f"{p['from_first_m'] / 1000:.1f} km from place 1"
        lines.append(f"  place {p['rank']}: {where}, pan {p['pan']:.1f}, fov {p['fov']:.1f}; score {p['score_px']:.2f} px; "
                     f"{what}")
    return lines


def places_skylines(places: list[dict], result, terrain) -> list[tuple[int, np.ndarray]]:
    """(rank, skyline (W,) rendered from the place at the photo's size with the place's own fov) for the places of
    :meth:`~skyrender.localizer.LocalizationResult.places`, for the overlay (one render for all of them)."""
    from .camera import Intrinsics
    from .render import render_skylines

    if not places or result.intrinsics is None:
        return []
    W, H = result.intrinsics.width, result.intrinsics.height
    poses = np.array([[p[k] for k in ("x", "y", "z", "pan", "tilt", "swing")] for p in places], np.float64)
    k = np.array([[Intrinsics.from_fov(p["fov"], W, H).f_px, W / 2.0, H / 2.0] for p in places])
    rendered = render_skylines(terrain, poses, Intrinsics(W, H, k[0, 0], W / 2.0, H / 2.0), per_pose_intrinsics=k)
    return [(p["rank"], rendered[i]) for i, p in enumerate(places)]


def places_geojson(places: list[dict]) -> list[dict]:
    """GeoJSON Point features of :meth:`~skyrender.localizer.LocalizationResult.places` (lon/lat where known,
    else world x, y), their ranks, scores and poses as properties."""
    return [{"type": "Feature", "properties": {"kind": "candidate place", **{k: v for k, v in p.items() if k not in
                                                                                ("lat", "lon")}},
             "geometry": {"type": "Point", "coordinates": [p["lon"], p["lat"]] if p["lat"] is not None
                          else [p["x"], p["y"]]}} for p in places]


def second_opinion_text(second_opinion: dict | None, localized: bool, agree_m: float = 1000.0) -> str:
    """What the CLI says of a second opinion (``LocalizeStats.second_opinion``; None: none asked): that a search
    with the fov unknown agreed with the answer (its best place within ``agree_m``), or where it ended instead. The
    search took as long again, and an analyst weighs an answer it agreed with, or a place it found elsewhere,
    differently."""
    if not second_opinion:
        return ""
    apart = float(second_opinion["apart_m"])
    far = f"{apart / 1000:.1f} km" if apart >= 1000 else f"{apart:.0f} m"
    if localized:
        return f" (a second search with the fov unknown agreed: its best place {far} away)"
    if apart <= agree_m:
        return f"; a second search with the fov unknown agreed ({far} away), not enough to answer"
    return f"; a second search with the fov unknown ended {far} away"


@app.command()
def mesh(
    dem: str = typer.Argument(..., help=DEM_HELP),
    out: Path = typer.Option(..., "--out", help="mesh file to write: .ply, .obj or .glb"),
    world: bool = typer.Option(False, "--world", help="world coordinates (default: local to the DEM centre, "
                               "as the float32 renderer uses them)"),
    curvature: bool = typer.Option(False, "--curvature", help="lower the terrain by earth curvature and refraction "
                                   "as seen from the DEM centre"),
    json_out: bool = typer.Option(False, "--json", help="print the summary as one JSON object"),
    crs: Optional[str] = CrsOpt,
    cell_size: Optional[float] = CellOpt,
    dem_bounds: Optional[str] = BoundsOpt,
):
    """Export the terrain mesh (trimesh) and, for PLY/OBJ, a Mitsuba scene XML beside it."""
    from .render.mesh_export import MESH_SUFFIXES, export_terrain

    _check_writable(out, "--out", MESH_SUFFIXES)
    terrain_dem = _load_dem(dem, crs, cell_size, dem_bounds)
    written = export_terrain(terrain_dem, str(out), world=world, curvature=curvature)
    rows, cols = terrain_dem.shape
    summary = {"files": written, "vertices": rows * cols, "faces": 2 * (rows - 1) * (cols - 1),
               "origin_xy": [0.0, 0.0] if world else [float(v) for v in terrain_dem.centre], "crs": terrain_dem.crs}
    if json_out:
        emit_json(summary)
    else:
        typer.echo(f"wrote {', '.join(written)}: {summary['vertices']} vertices, {summary['faces']} triangles")


def _parse_prior(prior_peak, prior_near) -> dict | None:
    prior: dict = {}
    if prior_peak:
        prior["ids"] = list(prior_peak)
    if prior_near:
        try:
            x, y, r = (float(v) for v in prior_near.split(","))
        except ValueError:
            raise InputError(f"--prior-near must be X,Y,RADIUS in metres, got {prior_near!r}") from None
        prior.update(x=x, y=y, radius=r)
    return prior or None


#: The share of a DEM's cells far from any data (``RepairReport.invented``) from which commands warn: ordinary SRTM
#: voids stay below it (the CH1 windows without a missing tile: at most 0.1 %)
INVENTED_WARNING_SHARE = 0.01


def _load_dem(dem, crs, cell_size, bounds=None):
    """The DEM of a ``--dem`` value (:func:`skyrender.dem.load_dem`), with a warning (:func:`_warn`) where
    much of it is invented (voids far from any data: a missing tile in a box of tiles). ``bounds``: the
    ``--dem-bounds`` text, W,S,E,N in the raster files' CRS."""
    from .dem import load_dem
    from .dem.io import BUILTIN_DEMS, SkippedTilesWarning

    window = None
    if bounds is not None:
        try:
            window = tuple(float(v) for v in bounds.split(","))
        except ValueError:
            window = ()
        if len(window) != 4 or not all(np.isfinite(window)) or not (window[0] < window[2] and window[1] < window[3]):
            raise InputError(f"--dem-bounds must be W,S,E,N with W < E and S < N, got {bounds!r}")
        if str(dem) in BUILTIN_DEMS or str(dem).lower().endswith((".npy", ".npz")):
            raise InputError("--dem-bounds needs raster DEM files (.tif, .hgt, .asc, .vrt), not a built-in or numpy DEM")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SkippedTilesWarning)
        terrain_dem = load_dem(dem, crs=crs, cell_size=cell_size, bounds=window)
    for warning in caught:
        if issubclass(warning.category, SkippedTilesWarning):
            _warn(str(warning.message))
    share = terrain_dem.repair.invented / terrain_dem.elevation.size
    if share >= INVENTED_WARNING_SHARE:
        _warn(f"{terrain_dem.name}: {100 * share:.0f} % of the DEM lies far from any elevation data (a missing tile, "
              "or no data outside an outline); the terrain there is invented")
    return terrain_dem


def _load_or_build_model(model_dir, dem, crs, cell_size, bounds, variant, params=None, progress: bool = False):
    """The model from --model, or built from --dem with ``params`` (ModelParams; None:
    the defaults) and cached (:func:`skyrender.model.cached_model`; ``progress``: say so on
    stderr while it is built)."""
    from .backend import mitsuba
    from .model import ModelParams, cached_model, load_model

    if model_dir is not None:
        if bounds is not None:
            raise InputError("--dem-bounds goes with --dem, not --model")
        return _warn_if_coarse(load_model(model_dir))
    terrain_dem = _load_dem(dem, crs, cell_size, bounds)
    mitsuba(variant)
    return _warn_if_coarse(cached_model(terrain_dem, ModelParams() if params is None else params, progress=progress))


def _warn_if_coarse(model):
    """``model``, after a warning (:func:`_warn`) where its DEM is so large that the far horizons stand on a coarser
    grid than its parameters ask for (``HorizonParams.max_centres``): the far-horizon search then proposes
    places that far apart, and a photo's place may be missed."""
    from .model.horizons import grid_spacing

    wanted = model.params.horizons.spacing
    spacing = grid_spacing(model.dem.extent, model.params.horizons)
    if spacing > 1.05 * wanted:
        x0, x1, y0, y1 = model.dem.extent
        _warn(f"the DEM covers {(x1 - x0) * (y1 - y0) / 1e6:,.0f} km^2, so its far horizons stand {spacing:,.0f} m apart "
              f"instead of {wanted:,.0f} m; cut to the photo's region (--dem-bounds W,S,E,N; at most "
              f"{model.params.horizons.max_centres * wanted ** 2 / 1e6:,.0f} km^2), it searches finer")
    return model


def _check_model_dir(path: Path) -> None:
    """Create the model directory now, so a bad --out fails before minutes of work."""
    if path.exists() and not path.is_dir():
        raise InputError(f"--out {path} exists and is not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out: cannot create {path}: {exc.strerror or exc}") from None
    if not os.access(path, os.W_OK):
        raise InputError(f"--out: {path} is not writable")


#: Highest camera height above ground accepted (m): beyond it the terrain is a speck.
MAX_HEIGHT_M = 20_000.0
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")
SKYLINE_SUFFIXES = (".npy", ".json")


def _check_writable(path: Path, option: str, suffixes: tuple[str, ...] | None = None) -> None:
    """Fail before any work when an output cannot be written (or has the wrong kind of name)."""
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(f"{option} {path}: the name must end in {', '.join(suffixes)}")
    if path.is_dir():
        raise InputError(f"{option} {path} is a directory")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{option}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"{option}: directory {parent} is not writable")


def _click_classes(name: str) -> tuple[type, ...]:
    """The click exception class ``name`` from click and from typer's vendored copy."""
    import importlib

    found = []
    for module in ("click.exceptions", "typer._click.exceptions"):
        try:
            found.append(getattr(importlib.import_module(module), name))
        except (ImportError, AttributeError):
            pass
    return tuple(found)


@app.callback()
def _root() -> None:
    """Camera pose from one mountain photograph and a DEM."""


@app.command()
def dataset(
    scene: Path = typer.Argument(..., help="scene file (scenes/*.toml) with a [dataset] table, or any scene"),
    n: int = typer.Option(..., "--n", help="views to render"),
    out: Path = typer.Option(..., "--out", help="dataset folder (views already there are kept: resuming)"),
    seed: int = typer.Option(0, "--seed", help="seed: the same seed gives the same files"),
    workers: int = typer.Option(0, "--workers", help="render on a local Dask cluster of this many processes"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="render on this Dask scheduler (tcp://host:port)"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """Write a frozen synthetic dataset: photos, poses, true skylines, sky masks, a manifest."""
    from .datasets.synthetic import write_dataset

    if not 0 <= seed < 2**32 or workers < 0:
        raise InputError("--seed must lie in [0, 2^32) and --workers be >= 0")
    info = write_dataset(str(scene), n, str(out), seed, progress=not quiet, workers=workers, scheduler=scheduler)
    typer.echo(f"wrote {info['views']} views of {info['dem']} to {out} (seed {seed})")


@app.command()
def experiment(
    config: Path = typer.Argument(..., help="experiment config (experiments/NAME.toml)"),
    out: Optional[Path] = typer.Option(None, "--out", help="results folder (default: NAME/results beside the config)"),
    workers: Optional[int] = typer.Option(None, "--workers", help="run on a local Dask cluster of this many processes"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="run on this Dask scheduler (tcp://host:port)"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bars"),
    tables_only: bool = typer.Option(False, "--tables-only", help="run nothing: tables and plots of the results so far"),
):
    """Localize every view of the datasets with every configuration; write results, tables and plots."""
    from .experiment import load_experiment, run_experiment

    if workers is not None and workers < 0:
        raise InputError(f"--workers must be >= 0, got {workers}")
    exp = load_experiment(str(config), None if out is None else str(out))
    result = run_experiment(exp, workers=workers, scheduler=scheduler, progress=not quiet, tables_only=tables_only)
    typer.echo(result["tables"])
    typer.echo(f"results in {exp.out}")


#: Warnings of the running command (:func:`_warn`), printed on stderr when it ends without an error: an error
#: stays the one line on stderr that CONTRACT.md promises
_WARNINGS: list[str] = []


def _warn(message: str) -> None:
    _WARNINGS.append(message)


def _print_warnings() -> None:
    for message in _WARNINGS:
        print(f"skyrender: warning: {message}", file=sys.stderr)
    _WARNINGS.clear()


def main(argv: list[str] | None = None) -> int:
    """Entry point: run the app, turning bad input into one line and exit status 2 (warnings, on stderr, only
    where it ends without an error)."""
    command = typer.main.get_command(app)
    _WARNINGS.clear()
    try:
        with warnings.catch_warnings():  # a library's warning is not ours to print: one line per error
            warnings.simplefilter("ignore")
            rv = command.main(args=argv, prog_name="skyrender", standalone_mode=False)
        _print_warnings()
        return int(rv) if isinstance(rv, int) else 0
    except InputError as exc:
        _fail(str(exc))
        return 2
    except _click_classes("Exit") as exc:
        if exc.exit_code != 2:
            _print_warnings()
        return exc.exit_code
    except _click_classes("ClickException") as exc:  # usage errors: missing option, bad number, ...
        if exc.format_message():  # (no arguments at all: the help was printed)
            _fail(exc.format_message())
        return 2
    except _click_classes("Abort"):
        _fail("aborted")
        return 1
    except KeyboardInterrupt:
        _fail("interrupted")
        return 130
    except Exception as exc:  # a bug: still one line, the traceback on request
        if os.environ.get("SKYRENDER_DEBUG"):
            raise
        _fail(f"internal error: {type(exc).__name__}: {exc} (set SKYRENDER_DEBUG=1 for the traceback)")
        return 1


def _fail(message: str) -> None:
    first = " ".join(str(message).split())
    print(f"skyrender: error: {first}", file=sys.stderr)


def run() -> None:
    """The command: exit with :func:`main`'s status (entered through :mod:`skyrender.__main__`)."""
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    run()
