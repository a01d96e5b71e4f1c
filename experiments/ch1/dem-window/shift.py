"""How far the old `--dem-bounds` merge moved each CH1 place's DEM (`skyrender/dem/io.py` before the window was
grown to whole cells): rasterio.merge on the window's raw corners starts its grid at the corner, and every cell
takes the nearest post, so the whole grid stood off the posts by the corner's fraction of a cell.

Measured, not derived: each place's tiles merged both ways (raw corners, as before; corners grown to whole cells,
as now), the old grid matched to the new one by a whole-cell offset, and the two grids' georeferences compared.

    python experiments/ch1/dem-window/shift.py > experiments/ch1/dem-window/shift.txt
"""

import math

import numpy as np
import rasterio
from rasterio.merge import merge

from skyrender.benchmarks.real_localize import place_window, places_of
from skyrender.datasets.real_photos import items_on_side
from skyrender.dem.io import _snap_window
from skyrender.diagnostics.oracle import tiles_around


def merged(paths, bounds):
    sources = [rasterio.open(p) for p in paths]
    try:
        data, transform = merge(sources, bounds=bounds, nodata=-32768)
        return data[0].astype(np.float64), transform, sources[0].transform
    finally:
        for s in sources:
            s.close()


def old_grid_shifts(lat, lon):
    """{(east, north) metres by which the old merge showed posts away from where they stand: share of the grid}.
    Each cell of the old grid is matched to the new grid's post it holds (a whole-cell offset; flat ground, where
    several offsets match, takes the first), so tiles rounded differently at a seam show as two shifts."""
    window = place_window(lat, lon)
    paths = tiles_around(lat, lon)
    old, old_t, tile_t = merged(paths, window)
    new, new_t, _ = merged(paths, _snap_window(window, tile_t))
    inner = old[2:-2, 2:-2]
    offsets = [(di, dj) for di in (0, 1, -1) for dj in (0, 1, -1)]
    matched = np.full(inner.shape, -1)
    for k, (di, dj) in enumerate(offsets):
        candidate = new[2 + di:2 + di + inner.shape[0], 2 + dj:2 + dj + inner.shape[1]]
        matched[(matched < 0) & (candidate == inner)] = k
    shifts = {}
    for k, (di, dj) in enumerate(offsets):
        share = float(np.mean(matched == k))
        if share > 0.05:
            # old cell (0, 0) holds the post of new cell (di, dj): where it is shown minus where it stands
            shown_x, shown_y = old_t * (0.5, 0.5)
            true_x, true_y = new_t * (0.5 + dj, 0.5 + di)
            shifts[(round((shown_x - true_x) * 111_320 * math.cos(math.radians(lat)), 1),
                    round((shown_y - true_y) * 110_570, 1))] = share
    return shifts


def main():
    for side in ("train", "dev", "validation"):
        items = [it for it in items_on_side(side) if it.key.startswith("ch1/")]
        _, centres = places_of(items)
        sizes = []
        for place, (lat, lon) in sorted(centres.items()):
            shifts = old_grid_shifts(lat, lon)
            sizes += [math.hypot(*en) for en in shifts]
            parts = "; ".join(f"{e:+5.1f} E {n:+5.1f} N on {100 * share:.0f} %" for (e, n), share in shifts.items())
            print(f"{side:10s} {place:14s} posts shown off by (m): {parts}")
        print(f"{side}: {len(centres)} places, posts shown {min(sizes):.0f}-{max(sizes):.0f} m from where they stand\n")


if __name__ == "__main__":
    main()
