"""Realistic synthetic photographs of the terrain.

Every pixel (supersampled on a regular sub-pixel grid) casts a primary ray
into the Mitsuba scene; hits are shaded with a sun (Lambert + cast shadows
by a second ray test), an albedo that varies with elevation, slope and a
deterministic texture (forest, meadow, rock, snow), and aerial-perspective
haze with distance; misses get a sky gradient with a sun glow. Sky types
(``Look.sky``): clear, hazy, overcast (diffuse light, grey sky) and sunset (a
warm, bright sky behind dark, back-lit terrain). Optional sensor noise,
foreground occluders (conifers and posts rising above the skyline), cloud banks
sitting on the ridges (behind the terrain: the skyline stays the terrain's) and
power lines across the frame (cables count as sky, as in the CH1 masks).
Everything is deterministic for a given ``seed``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Intrinsics, Pose, pixel_ray_basis
from .skyline import render_skylines
from .terrain import Terrain


@dataclass(frozen=True)
class Look:
    """Appearance of a rendered photograph (angles in degrees, lengths in metres)."""

    sun_azimuth: float = 135.0
    sun_elevation: float = 35.0
    haze_distance: float = 40_000.0  # e-folding distance of aerial perspective
    snowline: float | None = None  # gentle slopes above it are snow; None: the higher of 2400 m and the 85th percentile
    noise: float = 0.0  # std of Gaussian sensor noise, in [0, 1] intensity units
    occluders: float = 0.0  # share of columns covered by foreground trees/posts
    supersample: int = 2  # samples per pixel side
    seed: int = 0
    sky_horizon: tuple[float, float, float] = (0.78, 0.84, 0.90)
    sky_zenith: tuple[float, float, float] = (0.25, 0.45, 0.80)
    sky: str = "clear"  # clear (the two colours above), hazy, overcast, sunset
    clouds: float = 0.0  # in [0, 1]: cover of the cloud banks that sit on the ridges
    power_lines: int = 0  # cables sagging across the frame


# sky type -> (horizon colour, zenith colour, direct sunlight, sun glow); clear uses Look's colours
SKY_TYPES = {
    "clear": (None, None, 1.4, 0.5),
    "hazy": ((0.86, 0.87, 0.88), (0.58, 0.66, 0.80), 1.0, 0.6),
    "overcast": ((0.80, 0.80, 0.82), (0.68, 0.69, 0.72), 0.15, 0.05),
    "sunset": ((1.00, 0.62, 0.34), (0.30, 0.33, 0.56), 0.25, 1.2),
}


def sky_palette(look: Look) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(horizon RGB, zenith RGB, direct-light factor, glow factor) of ``look.sky``."""
    if look.sky not in SKY_TYPES:
        raise ValueError(f"unknown sky type {look.sky!r} (one of {', '.join(SKY_TYPES)})")
    horizon, zenith, direct, glow = SKY_TYPES[look.sky]
    if horizon is None:
        horizon, zenith = look.sky_horizon, look.sky_zenith
    return np.array(horizon), np.array(zenith), direct, glow


@dataclass(frozen=True)
class Photo:
    """A rendered photograph and its ground truth.

    image : (H, W, 3) uint8 sRGB.
    skyline : (W,) the terrain's sub-pixel skyline (README, Conventions).
    sky_boundary : (W,) boundary of the visible sky, occluders included.
    depth : (H, W) nearest terrain distance (m) among each pixel's samples; inf for sky.
    """

    image: np.ndarray
    skyline: np.ndarray
    sky_boundary: np.ndarray
    depth: np.ndarray


def cast_pixel_rays(terrain: Terrain, pose: Pose, intrinsics: Intrinsics, supersample: int = 1):
    """Primary rays through a regular grid of ``supersample``^2 points per pixel.

    Returns (t, points, normals, directions) for an (H*s, W*s) sample grid: distance
    (m, inf for sky), world hit points, unit normals, unit ray directions.
    """
    s = int(supersample)
    W, H = intrinsics.width, intrinsics.height
    offsets = (np.arange(s) + 0.5) / s
    u = (np.arange(W)[:, None] + offsets[None, :]).ravel()
    v = (np.arange(H)[:, None] + offsets[None, :]).ravel()
    d0, du, dv = pixel_ray_basis(pose, intrinsics.array())
    dirs = d0[0] + u[None, :, None] * du[0] + v[:, None, None] * dv[0]  # (H*s, W*s, 3)
    dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
    flat = dirs.reshape(-1, 3)
    origins = np.broadcast_to(pose.array()[:3], flat.shape)
    t, points, normals = terrain.intersect(origins, flat)
    shape = dirs.shape[:2]
    return t.reshape(shape), points.reshape(shape + (3,)), normals.reshape(shape + (3,)), dirs


def _texture(x, y, seed: int) -> np.ndarray:
    """Deterministic multi-scale texture in [-1, 1] from world x, y (metres)."""
    rng = np.random.default_rng(seed)
    out = np.zeros_like(x)
    for wavelength in (37.0, 110.0, 340.0):
        kx, ky, phase = rng.normal(size=3)
        out += np.sin((kx * x + ky * y) / wavelength + phase * 6.28) * np.cos((ky * x - kx * y) / (1.3 * wavelength))
    return out / 3.0


def _albedo(points, normals, snowline: float, zmin: float, zmax: float, seed: int) -> np.ndarray:
    forest = np.array([0.10, 0.14, 0.07])
    meadow = np.array([0.28, 0.32, 0.15])
    rock = np.array([0.36, 0.34, 0.31])
    snow = np.array([0.90, 0.92, 0.95])
    z = points[..., 2]
    slope = np.degrees(np.arccos(np.clip(np.abs(normals[..., 2]), 0, 1)))
    tex = _texture(points[..., 0], points[..., 1], seed)
    e = np.clip((z - zmin) / max(zmax - zmin, 1.0), 0, 1)
    green = forest + (meadow - forest) * np.clip(e * 1.6 + 0.2 * tex, 0, 1)[..., None]
    rockiness = np.clip((slope - 30.0) / 15.0 + (e - 0.6) * 2.0 + 0.3 * tex, 0, 1)[..., None]
    colour = green + (rock - green) * rockiness
    snowiness = np.clip((z - snowline) / 150.0 + 0.5 * tex, 0, 1) * np.clip((50.0 - slope) / 10.0, 0, 1)
    colour = colour + (snow - colour) * snowiness[..., None]
    return colour * (1.0 + 0.12 * tex)[..., None]


def _sky(dirs, look: Look, sun) -> np.ndarray:
    elevation = np.arcsin(np.clip(dirs[..., 2], -1, 1))
    w = np.clip(elevation / np.radians(35.0), 0, 1) ** 0.6
    horizon, zenith, _, glow_factor = sky_palette(look)
    sky = horizon + (zenith - horizon) * w[..., None]
    glow = np.exp(-np.arccos(np.clip(dirs @ sun, -1, 1)) / 0.12)
    return sky + glow_factor * glow[..., None]


def _smooth_noise(shape: tuple[int, int], cells: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """Smooth random field on a grid of ``shape``: a ``cells`` grid of normal values, up-sampled bicubically."""
    import cv2

    coarse = rng.normal(size=(cells[0] + 3, cells[1] + 3)).astype(np.float32)
    big = cv2.resize(coarse, (shape[1] * (cells[1] + 3) // cells[1], shape[0] * (cells[0] + 3) // cells[0]),
                     interpolation=cv2.INTER_CUBIC)
    return big[: shape[0], : shape[1]]


def _cloud_banks(shape: tuple[int, int], s: int, skyline: np.ndarray, look: Look) -> np.ndarray:
    """(H*s, W*s) cloud opacity in [0, 1]: banks of fractal cloud resting on the skyline,
    up to a third of the frame high; ``look.clouds`` sets their cover."""
    Hs, Ws = shape
    rng = np.random.default_rng(look.seed + 104729)
    noise = sum(_smooth_noise(shape, (max(2, Hs // (s * c)), max(2, Ws // (s * c))), rng) / k
                for c, k in ((64, 1.0), (24, 2.0), (8, 4.0)))
    noise = (noise - noise.mean()) / max(float(noise.std()), 1e-6)
    ground = np.where(np.isfinite(skyline), skyline, Hs / s * 0.6)
    top = np.repeat(ground, s)[None, :] * s
    rows = np.arange(Hs)[:, None] + 0.5
    thickness = Hs / 3.0 * (0.4 + 0.6 * np.clip(0.5 + 0.5 * _smooth_noise((1, Ws), (1, 4), rng), 0, 1))
    near_ridge = np.clip(1.0 - (top - rows) / thickness, 0, 1)
    threshold = 1.2 - 2.4 * np.clip(look.clouds, 0, 1)
    return np.clip((noise + 1.5 * near_ridge - 1.0 - threshold) / 0.6, 0, 1)


def _power_lines(shape: tuple[int, int], s: int, look: Look) -> np.ndarray:
    """(H*s, W*s) bool: ``look.power_lines`` sagging cables, 1-2 px thick, across the frame."""
    Hs, Ws = shape
    rng = np.random.default_rng(look.seed + 15485863)
    u = (np.arange(Ws) + 0.5) / Ws
    rows = np.arange(Hs)[:, None] + 0.5
    mask = np.zeros(shape, dtype=bool)
    for _ in range(int(look.power_lines)):
        v0, sag, centre = rng.uniform(0.05, 0.45) * Hs, rng.uniform(0.02, 0.2) * Hs, rng.uniform(0.2, 0.8)
        tilt = rng.uniform(-0.1, 0.1) * Hs
        v = v0 + tilt * (u - 0.5) + sag * ((u - centre) / max(centre, 1 - centre)) ** 2
        mask |= np.abs(rows - v[None, :]) <= 0.5 * s * rng.uniform(1.0, 2.0)
    return mask


def _occluders(W: int, H: int, s: int, skyline: np.ndarray, look: Look):
    """Foreground trees/posts: (coverage mask on the sample grid, colour, top edge per column).

    Each occluder rises 6-50 px above the local skyline; they are added until
    ``look.occluders`` of the columns have their skyline hidden.
    """
    rng = np.random.default_rng(look.seed + 7919)
    mask = np.zeros((H * s, W * s), dtype=bool)
    colour = np.zeros((H * s, W * s, 3))
    top = np.full(W, np.inf)
    target = look.occluders * W
    uu = (np.arange(W * s) + 0.5) / s
    vv = (np.arange(H * s) + 0.5) / s
    ground = np.where(np.isfinite(skyline), skyline, H * 0.6)
    for _ in range(200):
        if np.sum(top < ground) >= target:
            break
        centre = rng.uniform(0, W)
        i = int(np.clip(centre, 0, W - 1))
        if rng.random() < 0.6:  # conifer: a triangle crown on a trunk
            half = rng.uniform(6, 30)
            apex = ground[i] - rng.uniform(8, 50)
            height = half * rng.uniform(2.5, 4.0)
            width_at = np.clip((vv[:, None] - apex) / height, 0, None) * half
            shape = (np.abs(uu[None, :] - centre) <= width_at) & (vv[:, None] >= apex) & (vv[:, None] <= apex + height)
            shape |= (np.abs(uu[None, :] - centre) <= half * 0.12) & (vv[:, None] >= apex + height)
            tint = np.array([0.05, 0.09, 0.04]) * rng.uniform(0.7, 1.3)
            cols = np.arange(max(0, int(centre - half)), min(W, int(np.ceil(centre + half)) + 1))
            colu = cols + 0.5
            edge = apex + np.abs(colu - centre) / half * height
            top[cols] = np.minimum(top[cols], np.where(np.abs(colu - centre) <= half, edge, np.inf))
        else:  # post: a thin vertical bar
            half = rng.uniform(1.5, 5)
            apex = ground[i] - rng.uniform(6, 40)
            shape = (np.abs(uu[None, :] - centre) <= half) & (vv[:, None] >= apex)
            tint = np.array([0.16, 0.12, 0.08]) * rng.uniform(0.7, 1.3)
            cols = np.arange(max(0, int(centre - half)), min(W, int(np.ceil(centre + half)) + 1))
            inside = np.abs(cols + 0.5 - centre) <= half
            top[cols[inside]] = np.minimum(top[cols[inside]], apex)
        colour[shape & ~mask] = tint
        mask |= shape
    return mask, colour, np.maximum(top, 0.0)


def render_photo(terrain: Terrain, pose: Pose, intrinsics: Intrinsics, look: Look = Look()) -> Photo:
    """Render a realistic photograph of the terrain from ``pose``; see :class:`Look`."""
    s = max(1, int(look.supersample))
    W, H = intrinsics.width, intrinsics.height
    t, points, normals, dirs = cast_pixel_rays(terrain, pose, intrinsics, s)
    hit = np.isfinite(t)
    az, el = np.radians(look.sun_azimuth), np.radians(look.sun_elevation)
    sun = np.array([np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)])
    normals = np.where(normals[..., 2:3] < 0, -normals, normals)

    colour = _sky(dirs, look, sun)
    horizon, _, direct, _ = sky_palette(look)
    skyline = render_skylines(terrain, pose, intrinsics)
    if look.clouds > 0:
        cloud = _cloud_banks(colour.shape[:2], s, skyline, look)[..., None]
        shade = 0.93 - 0.25 * np.clip(_smooth_noise(colour.shape[:2], (max(2, H // 16), max(2, W // 16)),
                                                     np.random.default_rng(look.seed + 3)), 0, 1)[..., None]
        colour = colour * (1 - cloud) + (shade * (0.5 + 0.5 * horizon)) * cloud
    if hit.any():
        z = terrain.dem.elevation
        snowline = max(2400.0, float(np.quantile(z, 0.85))) if look.snowline is None else look.snowline
        p, n = points[hit], normals[hit]
        lit = np.clip(n @ sun, 0, None)
        shadow_from = p + 0.5 * n
        in_shadow = terrain.ray_test(shadow_from, np.broadcast_to(sun, p.shape), viewer_xy=shadow_from[:, :2])
        albedo = _albedo(p, n, snowline, float(z.min()), float(z.max()), look.seed)
        sky_light = horizon * (0.25 + 0.15 * n[:, 2:3])
        radiance = albedo * (sky_light + direct * (lit * ~in_shadow)[:, None])
        transmittance = np.exp(-t[hit] / look.haze_distance)[:, None]
        colour[hit] = radiance * transmittance + horizon * (1 - transmittance)

    sky_boundary = skyline.copy()
    if look.occluders > 0:
        mask, occ_colour, top = _occluders(W, H, s, skyline, look)
        colour[mask] = occ_colour[mask]
        sky_boundary = np.fmin(skyline, np.where(np.isfinite(top), top, np.nan))
    if look.power_lines > 0:
        colour[_power_lines(colour.shape[:2], s, look)] = (0.08, 0.08, 0.09)

    image = colour.reshape(H, s, W, s, 3).mean(axis=(1, 3))
    if look.noise > 0:
        image = image + np.random.default_rng(look.seed).normal(0, look.noise, image.shape)
    image = np.clip(image, 0, 1) ** (1 / 2.2)
    depth = t.reshape(H, s, W, s).min(axis=(1, 3))
    return Photo((image * 255 + 0.5).astype(np.uint8), skyline, sky_boundary, depth)
