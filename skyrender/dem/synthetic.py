"""Seeded fractal terrain, for tests and synthetic scenes.

The default mimics the DEM of Naval (2000): 600 x 600 cells at 50 m with a
couple of dominant mountains over rolling fractal relief. Placed in a real
UTM zone so lat/lon outputs work.
"""

from __future__ import annotations

import numpy as np
from affine import Affine

from .grid import DEM

DEFAULT_CRS = "EPSG:32632"
DEFAULT_ORIGIN = (400_000.0, 5_130_000.0)  # north-west corner, UTM 32N (the Alps)


def fractal_surface(shape: tuple[int, int], beta: float, rng: np.random.Generator) -> np.ndarray:
    """Zero-mean, unit-std Gaussian random field with power spectrum ~ 1/f^beta."""
    rows, cols = shape
    fy = np.fft.fftfreq(rows)[:, None]
    fx = np.fft.rfftfreq(cols)[None, :]
    f = np.hypot(fx, fy)
    f[0, 0] = 1.0
    amplitude = f ** (-beta / 2.0)
    amplitude[0, 0] = 0.0
    noise = rng.normal(size=(rows, cols // 2 + 1)) + 1j * rng.normal(size=(rows, cols // 2 + 1))
    field = np.fft.irfft2(noise * amplitude, s=(rows, cols))
    return (field - field.mean()) / field.std()


def fractal_terrain(size: int | tuple[int, int] = 600, cell_size: float = 50.0, seed: int = 0, *,
                    n_mountains: int = 2, mountain_height: float = 1400.0, relief: float = 350.0,
                    base: float = 1200.0, beta: float = 3.2, crs: str | None = DEFAULT_CRS,
                    origin: tuple[float, float] = DEFAULT_ORIGIN) -> DEM:
    """A deterministic synthetic DEM.

    Parameters
    ----------
    size : cells per side (or (rows, cols)).
    cell_size : metres per cell.
    seed : random seed; the same seed gives the same terrain.
    n_mountains : dominant mountains (ridged Gaussian massifs) added to the relief.
    mountain_height : their summit height above the base, metres.
    relief : standard deviation of the fractal relief, metres.
    base : mean elevation of the plain, metres.
    beta : spectral exponent of the relief (higher = smoother).
    """
    rows, cols = (size, size) if np.isscalar(size) else size
    rng = np.random.default_rng(seed)
    z = base + relief * fractal_surface((rows, cols), beta, rng)
    rr, cc = np.mgrid[0:rows, 0:cols].astype(np.float64)
    detail = fractal_surface((rows, cols), beta - 1.0, rng)
    for _ in range(n_mountains):
        r0, c0 = rng.uniform(0.25, 0.75) * rows, rng.uniform(0.25, 0.75) * cols
        radius = rng.uniform(0.07, 0.12) * min(rows, cols)
        height = mountain_height * rng.uniform(0.75, 1.0)
        d2 = ((rr - r0) ** 2 + (cc - c0) ** 2) / radius**2
        massif = np.exp(-d2) * (1.0 + 0.15 * detail)  # rough flanks, one dominant summit
        z += height * massif
    x0, y0 = origin
    return DEM(z, Affine(cell_size, 0.0, x0, 0.0, -cell_size, y0), crs, f"fractal(seed={seed})")
