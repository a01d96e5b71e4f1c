"""Frozen synthetic datasets: ``skyrender dataset SCENE.toml --n N --out DIR [--seed S]``.

Views are drawn the way photographs are taken, independently of the localizer:
a camera at a random position, ``height_m`` above the ground, turned towards the
part of its panorama (terrain beyond ``far_m``) with the most relief, tilted so that
the skyline sits in the upper part of the frame (or at a tilt drawn from ``tilt_deg``),
with a random swing and field of view; a view is kept when its true skyline crosses the frame (``min_terrain_columns``)
with enough relief (``min_relief`` of the image height, 5th to 95th percentile) and is
terrain beyond ``far_m`` on ``far_share`` of its columns (a photo of mountains, not of
the slope beside the camera). Nothing the localizer
uses (skyline peaks, model features) takes part in the choice.

Each view has its own random stream, ``default_rng([seed, index])``: a view is the
same whether it is rendered alone, resumed, or on another worker. Layout of ``DIR``::

    manifest.json              scene, DEM fingerprint, seed, sampling, realism, version, commit
    views/000000.png|.jpg      the photograph
    views/000000.json          pose and intrinsics (the fields of ``skyrender render --json``),
                               lat/lon, height above ground, look, lens distortion
    views/000000_skyline.npy   the true terrain skyline (v per column, README Conventions)
    views/000000_mask.png      255 where terrain or a foreground occluder is, 0 sky

Realism knobs (:class:`Realism`): sky types, sun, haze, noise, foreground occluders,
cloud banks on ridges, power lines, snow line, radial lens distortion (k1, k2: the
photo and its truth are warped alike; the pose stays the pinhole one), JPEG quality,
and the DEM mismatch ``localize_dem_block`` (experiments localize against the DEM's
block mean of that many cells: real photographs never match their DEM).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np

from ..camera import Intrinsics
from ..config import params_from_dict, params_to_dict
from ..errors import InputError
from ..progress import progress as progress_bar

FORMAT = "skyrender-dataset"
FORMAT_VERSION = 1


@dataclass(frozen=True)
class Sampling:
    """How views are drawn (angles in degrees, lengths in metres; ranges are [low, high])."""

    height_m: tuple = (1.5, 2.0)  # camera height above the ground
    fov_deg: tuple = (25.0, 75.0)  # horizontal field of view
    size: tuple = (640, 480)  # image width, height (px)
    swing_deg: float = 15.0  # uniform in +-this
    skyline_above_centre: tuple = (0.0, 0.3)  # the skyline's median sits this share of the height above the centre
    tilt_deg: tuple | None = None  # instead: the tilt drawn in this range (e.g. a level camera, as the paper's)
    min_relief: float = 0.04  # the true skyline spans at least this share of the image height (5th-95th pct)
    min_terrain_columns: float = 0.95  # share of columns whose skyline lies inside the frame
    far_m: float = 1000.0  # photos are of mountains: the skyline is terrain at least this far away...
    far_share: float = 0.5  # ...on at least this share of the columns (not a slope next to the camera)
    margin: float = 0.05  # share of the DEM's extent kept clear of cameras on each side
    max_draws: int = 200  # candidate views per kept view before giving up


@dataclass(frozen=True)
class Realism:
    """Appearance drawn per view (ranges are [low, high]; ``skies`` one of them uniformly)."""

    skies: tuple = ("clear",)  # of clear, hazy, overcast, sunset
    sun_azimuth_deg: tuple = (0.0, 360.0)
    sun_elevation_deg: tuple = (15.0, 60.0)
    haze_m: tuple = (20_000.0, 80_000.0)
    noise: tuple = (0.0, 0.0)
    occluders: tuple = (0.0, 0.0)
    clouds: tuple = (0.0, 0.0)
    power_lines: int = 0  # at most this many cables
    snowline_m: float | None = None  # None: the renderer's default
    k1: tuple = (0.0, 0.0)  # radial distortion x_d = x (1 + k1 r^2 + k2 r^4), r in focal lengths
    k2: tuple = (0.0, 0.0)
    jpeg_quality: int = 0  # 0: PNG; else JPEG at this quality
    localize_dem_block: int = 1  # DEM mismatch: experiments localize against this block mean
    supersample: int = 2


@dataclass(frozen=True)
class DatasetSpec:
    sampling: Sampling = field(default_factory=Sampling)
    realism: Realism = field(default_factory=Realism)


def dataset_spec(table: dict | None) -> DatasetSpec:
    """The scene file's ``[dataset]`` table as a :class:`DatasetSpec` (defaults for what it omits)."""
    spec = params_from_dict(DatasetSpec, table or {}, where="dataset.")
    s, r = spec.sampling, spec.realism
    for name, (lo, hi) in (("height_m", s.height_m), ("fov_deg", s.fov_deg)):
        if not 0 < lo <= hi:
            raise InputError(f"dataset.sampling.{name} must be a range [low, high] with 0 < low <= high")
    if s.fov_deg[1] >= 180 or min(s.size) < 16:
        raise InputError("dataset.sampling: fov below 180 deg and images at least 16 px a side")
    from ..render.photo import SKY_TYPES

    bad = [k for k in r.skies if k not in SKY_TYPES]
    if bad or not r.skies:
        raise InputError(f"dataset.realism.skies: one or more of {', '.join(SKY_TYPES)}, got {list(r.skies)}")
    if not 0 <= r.jpeg_quality <= 100 or r.localize_dem_block < 1:
        raise InputError("dataset.realism: jpeg_quality in 0..100, localize_dem_block >= 1")
    return spec


def _uniform(rng: np.random.Generator, bounds) -> float:
    lo, hi = (float(b) for b in bounds)
    return lo if hi <= lo else float(rng.uniform(lo, hi))


def relief_pan(horizon: np.ndarray, window_bins: int, rng: np.random.Generator) -> float:
    """A heading (deg, bin centres of a 1-deg ``horizon``) drawn with probability growing with
    the relief (max - min elevation) of the horizon in a window of ``window_bins`` centred on it:
    people photograph mountains, not plains."""
    n = len(horizon)
    idx = (np.arange(n)[:, None] + np.arange(window_bins)[None, :] - window_bins // 2) % n
    window = horizon[idx]
    relief = window.max(axis=1) - window.min(axis=1)
    weights = relief**2 + 1e-9
    return (float(rng.choice(n, p=weights / weights.sum())) + rng.uniform(-0.5, 0.5)) * 360.0 / n


#: A drawn view is drawn again where more of its skyline's columns than this lie on invented terrain
#: (:attr:`~skyrender.dem.DEM.invented`: a missing tile, no data outside an outline): its truth would be made up.
MAX_INVENTED_SKYLINE_SHARE = 0.05


def invented_skyline_share(dem, pose, intrinsics: Intrinsics, skyline: np.ndarray, distance: np.ndarray) -> float:
    """Share of the columns (0-1) whose skyline terrain, ``distance`` metres along the ray just below the
    boundary (:func:`~skyrender.render.render_skylines` ``with_distance``), stands on the DEM's invented cells."""
    from ..camera import pixel_directions

    seen = np.isfinite(skyline) & np.isfinite(distance)
    if not seen.any():
        return 0.0
    cols = np.flatnonzero(seen)
    rays = pixel_directions(cols + 0.5, np.minimum(skyline[cols] + 0.5, intrinsics.height - 0.5), pose, intrinsics)
    x = pose.x + distance[cols] * rays[:, 0]
    y = pose.y + distance[cols] * rays[:, 1]
    return float(np.count_nonzero(dem.is_invented(x, y))) / len(skyline)


def sample_view(terrain, index: int, seed: int, sampling: Sampling):
    """(pose, intrinsics, height above ground, true skyline) of view ``index``; InputError when
    ``sampling.max_draws`` candidates give no view with enough relief."""
    from ..render import render_skylines
    from ..render.horizon import render_horizons

    dem = terrain.dem
    rng = np.random.default_rng([seed, index])
    xmin, xmax, ymin, ymax = dem.extent
    mx, my = sampling.margin * (xmax - xmin), sampling.margin * (ymax - ymin)
    W, H = (int(v) for v in sampling.size)
    for _ in range(sampling.max_draws):
        x, y = rng.uniform(xmin + mx, xmax - mx), rng.uniform(ymin + my, ymax - my)
        if dem.is_invented(x, y):  # no camera on terrain the DEM's loading made up (a missing tile, outside an outline)
            continue
        height = _uniform(rng, sampling.height_m)
        intrinsics = Intrinsics.from_fov(_uniform(rng, sampling.fov_deg), W, H)
        z = float(dem.ground(x, y)) + height
        horizon = render_horizons(terrain, np.array([[x, y, z]]), bin_deg=1.0, near_m=sampling.far_m)[0]
        horizon = horizon.astype(np.float64)
        pan = relief_pan(horizon, max(2, int(round(intrinsics.fov))), rng)
        centre = (np.arange(-int(intrinsics.fov) // 2, int(intrinsics.fov) // 2 + 1) + int(round(pan))) % 360
        above = _uniform(rng, sampling.skyline_above_centre) * H
        tilt = float(np.median(horizon[centre])) - np.degrees(np.arctan(above / intrinsics.f_px))
        if sampling.tilt_deg is not None:
            tilt = _uniform(rng, sampling.tilt_deg)
        swing = _uniform(rng, (-sampling.swing_deg, sampling.swing_deg))
        pose = dem.camera_pose(x, y, height, pan, tilt, swing)
        if dem.invented is None:
            skyline = render_skylines(terrain, pose, intrinsics)
        else:
            skyline, distance = render_skylines(terrain, pose, intrinsics, with_distance=True)
            if invented_skyline_share(dem, pose, intrinsics, skyline, distance) > MAX_INVENTED_SKYLINE_SHARE:
                continue
        inside = np.isfinite(skyline) & (skyline > 0) & (skyline < H)
        if inside.mean() < sampling.min_terrain_columns:
            continue
        p5, p95 = np.percentile(skyline[inside], [5, 95])
        if p95 - p5 < sampling.min_relief * H:
            continue
        far = render_skylines(terrain, pose, intrinsics, near_m=sampling.far_m)
        if np.mean(np.abs(np.nan_to_num(far - skyline, nan=H)) <= 1.0) >= sampling.far_share:
            return pose, intrinsics, height, skyline
    raise InputError(f"no view with enough relief after {sampling.max_draws} draws (view {index}, seed {seed}): "
                     "lower dataset.sampling.min_relief or use a DEM with mountains")


def look_for(index: int, seed: int, realism: Realism):
    """The :class:`~skyrender.render.photo.Look` of view ``index`` (its own random stream)."""
    from ..render.photo import Look

    rng = np.random.default_rng([seed, index, 1])
    return Look(sun_azimuth=_uniform(rng, realism.sun_azimuth_deg), sun_elevation=_uniform(rng, realism.sun_elevation_deg),
                haze_distance=_uniform(rng, realism.haze_m), noise=_uniform(rng, realism.noise),
                occluders=_uniform(rng, realism.occluders), clouds=_uniform(rng, realism.clouds),
                power_lines=int(rng.integers(0, realism.power_lines + 1)), snowline=realism.snowline_m,
                sky=str(realism.skies[int(rng.integers(len(realism.skies)))]), seed=int(rng.integers(2**31)),
                supersample=realism.supersample)


def distortion_maps(intrinsics: Intrinsics, k1: float, k2: float) -> tuple[np.ndarray, np.ndarray]:
    """(map_u, map_v) float32 (H, W) for ``cv2.remap``: where in the pinhole image each pixel
    of the distorted one looks. The model is x_d = x_u (1 + k1 r_u^2 + k2 r_u^4) in focal
    lengths from the principal point; it is inverted by fixed-point iteration."""
    W, H, f = intrinsics.width, intrinsics.height, intrinsics.f_px
    u, v = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    xd, yd = (u - intrinsics.cx) / f, (v - intrinsics.cy) / f
    xu, yu = xd.copy(), yd.copy()
    for _ in range(20):
        r2 = xu * xu + yu * yu
        scale = 1.0 + k1 * r2 + k2 * r2 * r2
        xu, yu = xd / scale, yd / scale
    return ((xu * f + intrinsics.cx - 0.5).astype(np.float32), (yu * f + intrinsics.cy - 0.5).astype(np.float32))


def boundary_coverage(boundary: np.ndarray, H: int) -> np.ndarray:
    """(H, W) float32 share of each pixel below a per-column boundary (v, README Conventions;
    NaN: all sky): 1 terrain, 0 sky, fractional on the boundary row."""
    b = np.where(np.isfinite(boundary), boundary, H)
    return np.clip(np.arange(H)[:, None] + 1.0 - b[None, :], 0.0, 1.0).astype(np.float32)


def coverage_boundary(coverage: np.ndarray) -> np.ndarray:
    """Inverse of :func:`boundary_coverage` for a column with sky above terrain: the sky's
    share of the column, in rows; NaN where a column is all sky."""
    H = coverage.shape[0]
    v = np.sum(1.0 - coverage, axis=0, dtype=np.float64)
    return np.where(v >= H - 1e-3, np.nan, v)


def distort(image: np.ndarray, skyline: np.ndarray, sky_boundary: np.ndarray, intrinsics: Intrinsics,
            k1: float, k2: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The photo, its skyline and its sky boundary as a lens with radial distortion (k1, k2) sees them."""
    import cv2

    if k1 == 0 and k2 == 0:
        return image, skyline, sky_boundary
    mu, mv = distortion_maps(intrinsics, k1, k2)
    H = intrinsics.height

    def warp(a, border):
        return cv2.remap(a, mu, mv, cv2.INTER_LINEAR, borderMode=border)

    out = warp(image, cv2.BORDER_REFLECT)
    lines = [coverage_boundary(warp(boundary_coverage(b, H), cv2.BORDER_REPLICATE)) for b in (skyline, sky_boundary)]
    return out, lines[0], lines[1]


def view_record(dem, pose, intrinsics: Intrinsics, height: float, look, realism_k: tuple[float, float]) -> dict:
    """The view's JSON: ``skyrender render --json`` fields, lat/lon, height above ground, look, distortion."""
    from dataclasses import asdict

    record = {"x": pose.x, "y": pose.y, "z": pose.z, "pan": pose.pan, "tilt": pose.tilt, "swing": pose.swing,
              "fov": intrinsics.fov, "width": intrinsics.width, "height": intrinsics.height, "crs": dem.crs,
              "height_above_ground": height, "k1": realism_k[0], "k2": realism_k[1],
              "look": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(look).items()}}
    if dem.crs:
        lon, lat = dem.to_lonlat(pose.x, pose.y)
        record["lat"], record["lon"] = float(lat), float(lon)
    return record


def render_view(terrain, index: int, seed: int, spec: DatasetSpec) -> dict:
    """Everything of view ``index``: {"record", "image", "skyline", "mask"} (see the module doc)."""
    from ..render.photo import render_photo

    pose, intrinsics, height, _ = sample_view(terrain, index, seed, spec.sampling)
    look = look_for(index, seed, spec.realism)
    photo = render_photo(terrain, pose, intrinsics, look)
    rng = np.random.default_rng([seed, index, 2])
    k = (_uniform(rng, spec.realism.k1), _uniform(rng, spec.realism.k2))
    image, skyline, sky_boundary = distort(photo.image, photo.skyline, photo.sky_boundary, intrinsics, *k)
    mask = (boundary_coverage(sky_boundary, intrinsics.height) >= 0.5).astype(np.uint8) * 255
    return {"record": view_record(terrain.dem, pose, intrinsics, height, look, k), "image": image,
            "skyline": skyline.astype(np.float64), "mask": mask}


def view_paths(out: str, index: int, jpeg: bool) -> dict:
    stem = os.path.join(out, "views", f"{index:06d}")
    return {"image": stem + (".jpg" if jpeg else ".png"), "record": stem + ".json", "skyline": stem + "_skyline.npy",
            "mask": stem + "_mask.png"}


def write_view(out: str, index: int, view: dict, jpeg_quality: int) -> None:
    """Write one view's files; the JSON last, so a view with its JSON is complete (resuming)."""
    import cv2

    paths = view_paths(out, index, jpeg_quality > 0)
    bgr = np.ascontiguousarray(view["image"][..., ::-1])
    params = [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)] if jpeg_quality else [cv2.IMWRITE_PNG_COMPRESSION, 6]
    if not cv2.imwrite(paths["image"], bgr, params) or not cv2.imwrite(paths["mask"], view["mask"]):
        raise InputError(f"cannot write images under {out}")
    np.save(paths["skyline"], view["skyline"])
    with open(paths["record"], "w") as f:
        json.dump(view["record"], f, indent=1, sort_keys=True)


def manifest(scene_path: str, out: str, scene, seed: int, n: int, spec: DatasetSpec) -> dict:
    from .. import __version__
    from ..evaluate import git_commit

    # the scene relative to the dataset folder: the two move together, and the bytes do not name the machine
    return {"format": FORMAT, "version": FORMAT_VERSION, "scene": os.path.relpath(os.path.abspath(scene_path), out),
            "dem": scene.dem_ref,
            "dem_fingerprint": scene.dem.fingerprint(), "dem_name": scene.dem.name, "crs": scene.dem.crs, "seed": seed,
            "views": n, "sampling": params_to_dict(spec.sampling), "realism": params_to_dict(spec.realism),
            "skyrender": __version__, "commit": git_commit()}


def finished_views(out: str, n: int, jpeg: bool) -> list[int]:
    """Indices below ``n`` whose files are all written."""
    return [i for i in range(n) if all(os.path.exists(p) for p in view_paths(out, i, jpeg).values())]


def write_dataset(scene_path: str, n: int, out: str, seed: int = 0, *, progress: bool = True,
                  scheduler: str | None = None, workers: int = 0) -> dict:
    """Render ``n`` views of the scene into ``out`` (see the module doc); views already there
    are kept (resuming), so the same call twice renders each view once. The terrain is built
    once per process. ``workers`` > 0 or a ``scheduler`` address renders on Dask
    (:func:`render_on_dask`); the files are the same. Returns the manifest."""
    from ..scenes import load_scene

    if n < 1:
        raise InputError(f"--n must be >= 1, got {n}")
    scene = load_scene(scene_path)
    spec = dataset_spec(scene.dataset)
    info = manifest(scene_path, os.path.abspath(out), scene, seed, n, spec)
    _check_same_dataset(out, info)
    created = not os.path.exists(out)
    try:
        os.makedirs(os.path.join(out, "views"), exist_ok=True)
        with open(os.path.join(out, "manifest.json"), "w") as f:  # first: a resumed run checks against it
            json.dump(info, f, indent=1, sort_keys=True)
    except OSError as exc:
        raise InputError(f"cannot write the dataset to {out}: {exc.strerror}") from None
    jpeg = spec.realism.jpeg_quality > 0
    todo = [i for i in range(n) if i not in set(finished_views(out, n, jpeg))]
    try:
        if todo and (workers or scheduler):
            render_on_dask(scene_path, todo, out, seed, workers=workers, scheduler=scheduler, progress=progress)
        elif todo:
            from ..render import Terrain

            terrain = Terrain(scene.dem)
            for i in progress_bar(todo, "rendering views", progress, unit="view"):
                write_view(out, i, render_view(terrain, i, seed, spec), spec.realism.jpeg_quality)
    except BaseException:
        if created and not finished_views(out, n, jpeg):  # nothing of value written: leave no folder behind
            import shutil

            shutil.rmtree(out, ignore_errors=True)
        raise
    return info


def _check_same_dataset(out: str, info: dict) -> None:
    """Refuse to resume into a folder that holds another dataset (other scene, DEM, seed or knobs)."""
    path = os.path.join(out, "manifest.json")
    if not os.path.exists(path):
        return
    try:
        with open(path) as f:
            old = json.load(f)
    except (OSError, ValueError):
        raise InputError(f"{out} holds an unreadable manifest.json: not resuming into it") from None
    keys = ("format", "dem_fingerprint", "seed", "sampling", "realism")
    if any(old.get(k) != info[k] for k in keys):
        raise InputError(f"{out} holds another dataset (its DEM, seed or knobs differ): choose another --out")


# --- Dask --------------------------------------------------------------------------------
_WORKER_STATE: dict = {}


def _render_task(scene_path: str, index: int, out: str, seed: int) -> int:
    """One view on a Dask worker; the scene and terrain are built once per worker process."""
    from ..render import Terrain
    from ..scenes import load_scene

    key = ("scene", os.path.abspath(scene_path))
    if key not in _WORKER_STATE:
        scene = load_scene(scene_path)
        _WORKER_STATE[key] = (Terrain(scene.dem), dataset_spec(scene.dataset))
    terrain, spec = _WORKER_STATE[key]
    write_view(out, index, render_view(terrain, index, seed, spec), spec.realism.jpeg_quality)
    return index


def render_on_dask(scene_path: str, indices: list[int], out: str, seed: int, *, workers: int = 0,
                   scheduler: str | None = None, progress: bool = True) -> None:
    """Render views as Dask tasks, one view per task: on ``scheduler`` (an address) or on a
    ``distributed.LocalCluster`` of ``workers`` single-threaded processes."""
    from ..scale import dask_client

    with dask_client(workers=workers, scheduler=scheduler) as client:
        futures = client.map(_render_task, [scene_path] * len(indices), indices, [out] * len(indices),
                             [seed] * len(indices), pure=False)
        from distributed import as_completed

        for future in progress_bar(as_completed(futures), "rendering views", progress, total=len(futures), unit="view"):
            future.result()
