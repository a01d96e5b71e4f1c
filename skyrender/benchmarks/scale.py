"""``make bench-scale``: the localizer at scale, as a user runs it — time and peak memory per row.

Every figure is one ``skyrender`` command run in its own process, the way a user runs it:
``skyrender model DEM --out M`` (seconds and peak RSS of the build, DEM load included) and
``skyrender localize PHOTO --model M --height 2 --fov F --preset render --json`` per view
(the command's own ``seconds``, skyline extraction included; the process's wall seconds,
model and terrain loading included; its peak RSS). Peak RSS is the command's own
(``os.wait4`` in a small launcher process: see :data:`LAUNCHER`), so rows do not mix.

Rows (issue 22's table):

- ``synthetic``: ``builtin:naval2000`` (600² cells of 50 m), 1024 x 640 photos, fov 60, no prior.
- ``tile``: the whole SRTM3 tile N46E007 (Valais; ~77 x 111 km), fov drawn from 35-60 deg,
  1008 x 756 photos, no prior.
- ``tile1``: the same tile as a 1-arc-second GeoTIFF (3601² posts: the 3" posts kept, bilinear
  between; what SRTM1 / Copernicus GLO-30 tiles weigh) — model build, and the ``tile`` row's
  views (rendered from the 3" grid: a mild DEM mismatch) localized on it.
- ``mosaic``: 2 x 2 tiles (N46E007, N46E008, N47E007, N47E008) as one DEM: build and localize.

Views are rendered photos with known poses (:func:`~skyrender.benchmarks.views.sample_views`,
camera 2 m up); errors are to the true position. Writes ``experiments/scale/bench-scale.{json,txt}``.

Usage: ``python -m skyrender.benchmarks.scale [--rows synthetic tile tile1 mosaic] [--views N]``
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

from ..evaluate import REPO
from . import write_figures

DEM_DIR = os.path.join(REPO, "..", "shared", "data", "dem")
TILE = "N46E007.hgt"
MOSAIC = ("N46E007.hgt", "N46E008.hgt", "N47E007.hgt", "N47E008.hgt")
#: A view counts as right within this distance of the true position (m).
RIGHT_M = 200.0
#: The figures before this benchmark existed, from issue 22 (2 cores): what each row is compared with.
ISSUE_FIGURES = {
    "synthetic": "median 8.9 s",
    "tile": "median 28.8 s, up to 38 s; 2.2 GB",
    "tile1_model": "91 s, 3.5 GB",
    "tile1": "median 41.5 s; 6/8 within 200 m",
}
GOALS = {
    "synthetic": "median <= 5 s",
    "tile": "median <= 20 s, max <= 60 s; <= 1.5 GB",
    "tile1_model": "<= 60 s, <= 3 GB",
    "tile1": "median <= 30 s; >= 90 % within 200 m",
    "mosaic": "within 4x the one-tile figures",
}


#: Runs a command and writes its exit status and peak RSS to a file. The benchmark's own process
#: holds the rendered views' DEM and model; a child forked from it inherits that high-water mark
#: (Linux keeps ``ru_maxrss`` across exec), so each command is started from this small launcher.
LAUNCHER = ("import json, os, subprocess, sys; p = subprocess.Popen(sys.argv[2:]); _, s, u = os.wait4(p.pid, 0); "
            "json.dump({'status': os.waitstatus_to_exitcode(s), 'maxrss_kb': u.ru_maxrss}, open(sys.argv[1], 'w'))")


def run_measured(args: list[str], timeout: float = 3600.0) -> dict:
    """Run a command; its wall seconds, peak RSS (GB, the command's own: started from
    :data:`LAUNCHER`), exit status, stdout and stderr."""
    t = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, \
            tempfile.NamedTemporaryFile("r", suffix=".json") as usage:
        # its own process group, so that a timeout stops the command too, not only the launcher
        launcher = subprocess.Popen([sys.executable, "-c", LAUNCHER, usage.name, *args], stdout=out, stderr=err,
                                    start_new_session=True)
        try:
            launcher.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(launcher.pid, signal.SIGKILL)
            launcher.wait()
            raise
        wall = time.perf_counter() - t
        measured = json.load(usage)
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read().decode(), err.read().decode()
    return {"wall_s": wall, "peak_gb": measured["maxrss_kb"] / 1e6, "status": measured["status"], "stdout": stdout,
            "stderr": stderr}


def stats_line(stderr: str) -> dict:
    """The ``stats: {...}`` line ``skyrender localize --stats`` prints on stderr ({} if none)."""
    for line in stderr.splitlines():
        if line.startswith("stats: "):
            return json.loads(line[len("stats: "):])
    return {}


def skyrender_command(*args: str) -> list[str]:
    """The ``skyrender`` command line, run by this interpreter."""
    return [sys.executable, "-m", "skyrender", *args]


def build(dem: str, out: str) -> dict:
    """``skyrender model DEM --out OUT``: build seconds (the command's own, DEM load included), peak RSS."""
    r = run_measured(skyrender_command("model", dem, "--out", out, "--json", "--no-progress"))
    if r["status"] != 0:
        raise RuntimeError(f"skyrender model {dem} failed: {r['stderr'][-2000:]}")
    d = json.loads(r["stdout"])
    return {"seconds": d["seconds"], "wall_s": r["wall_s"], "peak_gb": r["peak_gb"], "stage_seconds": d["stage_seconds"]}


def write_one_arc_second_tile(hgt: str, out: str) -> str:
    """A 1-arc-second GeoTIFF (3601 x 3601 posts, int16, EPSG:4326) of an SRTM3 tile: the 3"
    posts kept, bilinear between (``scipy.ndimage.zoom``, order 1)."""
    import rasterio
    from affine import Affine
    from scipy import ndimage

    with rasterio.open(hgt) as src:
        z = src.read(1).astype(np.float32)
        west, north = src.transform.c + src.transform.a / 2, src.transform.f + src.transform.e / 2  # first post
    fine = np.round(ndimage.zoom(z, 3601 / 1201, order=1, grid_mode=False)).astype(np.int16)
    step = 1.0 / 3600.0
    profile = {"driver": "GTiff", "width": 3601, "height": 3601, "count": 1, "dtype": "int16", "crs": "EPSG:4326",
               "transform": Affine(step, 0, west - step / 2, 0, -step, north + step / 2), "nodata": -32768,
               "compress": "deflate", "tiled": True}
    with rasterio.open(out, "w", **profile) as dst:
        dst.write(fine, 1)
    return out


def render_views(dem_path: str, model_dir: str, n: int, fovs: tuple[float, float], size: tuple[int, int],
                 out_dir: str, seed: int = 0) -> list[dict]:
    """``n`` rendered photos (PNG) of views with known poses (:func:`sample_views`), fov drawn
    uniformly from ``fovs``; returns per view its photo path, fov and true pose."""
    import cv2

    from ..camera import Intrinsics
    from ..dem import load_dem
    from ..model import load_model
    from ..render import Terrain
    from ..render.photo import Look, render_photo
    from .views import sample_views

    dem = load_dem(dem_path)
    terrain = Terrain(dem)
    model = load_model(model_dir, dem=dem)
    rng = np.random.default_rng(seed)
    views = []
    for i in range(n):
        fov = float(rng.uniform(*fovs)) if fovs[0] != fovs[1] else float(fovs[0])
        intr = Intrinsics.from_fov(fov, *size)
        pose = sample_views(terrain, model, intr, 1, seed=seed * 1000 + i).poses[0]
        photo = render_photo(terrain, pose, intr, Look(seed=i))
        path = os.path.join(out_dir, f"view{i:02d}.png")
        cv2.imwrite(path, cv2.cvtColor(photo.image, cv2.COLOR_RGB2BGR))
        views.append({"photo": path, "fov": fov, "pose": pose.array().tolist()})
    return views


def localize_views(views: list[dict], model_dir: str) -> list[dict]:
    """``skyrender localize`` per view (render preset, no prior, fov given): the command's
    seconds, wall seconds, peak RSS, status and position error (m)."""
    rows = []
    for v in views:
        r = run_measured(skyrender_command("localize", v["photo"], "--model", model_dir, "--height", "2",
                                           "--fov", f"{v['fov']:.4f}", "--preset", "render", "--json", "--stats"))
        stats = stats_line(r["stderr"])
        row = {"fov": v["fov"], "wall_s": r["wall_s"], "peak_gb": r["peak_gb"], "exit": r["status"],
               "stage_seconds": stats.get("seconds", {}), "stage_peak_mb": stats.get("peak_mb", {}),
               "hypotheses": stats.get("evaluated")}
        if r["status"] in (0, 3):
            d = json.loads(r["stdout"])
            row.update(seconds=d["seconds"], status=d["status"])
            row["error_m"] = (float(np.hypot(d["x"] - v["pose"][0], d["y"] - v["pose"][1]))
                              if d["status"] == "localized" else None)
        else:
            row.update(seconds=None, status="error", error_m=None, stderr=r["stderr"][-2000:])
        rows.append(row)
        error = "-" if row["error_m"] is None else f"{row['error_m']:.0f} m"
        seconds = float("nan") if row["seconds"] is None else row["seconds"]
        print(f"    {os.path.basename(v['photo'])}: fov {v['fov']:.1f}, {row['status']}, {error}, {seconds:.1f} s "
              f"(wall {row['wall_s']:.1f} s, {row['peak_gb']:.2f} GB)", flush=True)
    return rows


def summarize(rows: list[dict]) -> dict:
    """Median / max seconds (the command's own and wall), peak RSS, localized and right counts."""
    secs = np.array([r["seconds"] if r["seconds"] is not None else np.nan for r in rows], np.float64)
    wall = np.array([r["wall_s"] for r in rows])
    err = np.array([r["error_m"] if r["error_m"] is not None else np.nan for r in rows], np.float64)
    stages = sorted({k for r in rows for k in r.get("stage_seconds", {})})
    stage_median = {k: round(float(np.median([r.get("stage_seconds", {}).get(k, 0.0) for r in rows])), 2) for k in stages}
    return {"views": len(rows), "seconds_median": float(np.nanmedian(secs)), "seconds_max": float(np.nanmax(secs)),
            "stage_seconds_median": stage_median, "wall_median": float(np.median(wall)), "wall_max": float(wall.max()),
            "peak_gb": float(max(r["peak_gb"] for r in rows)), "localized": int(np.isfinite(err).sum()),
            "within_200m": int((err <= RIGHT_M).sum()), "errors_m": [None if not np.isfinite(e) else float(e) for e in err]}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m skyrender.benchmarks.scale", description=__doc__.splitlines()[0])
    parser.add_argument("--rows", nargs="+", default=["synthetic", "tile", "tile1", "mosaic"],
                        choices=["synthetic", "tile", "tile1", "mosaic"])
    parser.add_argument("--views", type=int, default=8, help="views per row (the mosaic gets half)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "scale"))
    args = parser.parse_args(argv)
    needs_tiles = [r for r in args.rows if r != "synthetic"]
    if needs_tiles and not os.path.exists(os.path.join(DEM_DIR, TILE)):
        print(f"no SRTM tiles at {DEM_DIR}: rows {needs_tiles} need them")
        return 2
    figures: dict = {}
    lines = []

    def report(name: str, text: str) -> None:
        line = f"{name:<12} {text}"
        lines.append(line)
        print(line, flush=True)

    with tempfile.TemporaryDirectory() as tmp:
        def row(name: str, dem: str, fovs, size, n, views=None):
            model_dir = os.path.join(tmp, f"model-{name}")
            print(f"{name}: building the model of {', '.join(os.path.basename(t) for t in dem.split(','))}", flush=True)
            b = build(dem, model_dir)
            if views is None:
                os.makedirs(os.path.join(tmp, name), exist_ok=True)
                views = render_views(dem, model_dir, n, fovs, size, os.path.join(tmp, name), args.seed)
            print(f"{name}: localizing {len(views)} views", flush=True)
            per_view = localize_views(views, model_dir)
            s = summarize(per_view)
            figures[name] = {"model": b, "localize": s, "views": per_view}
            report(name, f"model {b['seconds']:.1f} s, {b['peak_gb']:.2f} GB; localize median {s['seconds_median']:.1f} s "
                         f"(wall {s['wall_median']:.1f} s), max {s['seconds_max']:.1f} s (wall {s['wall_max']:.1f} s), "
                         f"peak {s['peak_gb']:.2f} GB; localized {s['localized']}/{s['views']}, within 200 m "
                         f"{s['within_200m']}")
            report("", "  model seconds by stage: " + ", ".join(f"{k} {v:.1f}" for k, v in b["stage_seconds"].items()))
            report("", "  localize median seconds by stage: " + ", ".join(
                f"{k} {v:.1f}" for k, v in sorted(s["stage_seconds_median"].items(), key=lambda kv: -kv[1]) if v >= 0.05))
            return views

        if "synthetic" in args.rows:
            row("synthetic", "builtin:naval2000", (60.0, 60.0), (1024, 640), args.views)
        tile_views = None
        if "tile" in args.rows or "tile1" in args.rows:
            tile = os.path.join(DEM_DIR, TILE)
            if "tile" in args.rows:
                tile_views = row("tile", tile, (35.0, 60.0), (1008, 756), args.views)
            else:  # tile1 alone: its views still come from the 3" tile
                model_dir = os.path.join(tmp, "model-tile-views")
                build(tile, model_dir)
                os.makedirs(os.path.join(tmp, "tile"), exist_ok=True)
                tile_views = render_views(tile, model_dir, args.views, (35.0, 60.0), (1008, 756),
                                          os.path.join(tmp, "tile"), args.seed)
        if "tile1" in args.rows:
            one = write_one_arc_second_tile(os.path.join(DEM_DIR, TILE), os.path.join(tmp, "N46E007_1arcsec.tif"))
            row("tile1", one, None, None, 0, views=tile_views)
        if "mosaic" in args.rows:
            row("mosaic", ",".join(os.path.join(DEM_DIR, t) for t in MOSAIC), (35.0, 60.0), (1008, 756),
                max(1, args.views // 2))
    lines.append("")
    for name, before in ISSUE_FIGURES.items():
        lines.append(f"before (issue 22) {name}: {before}; goal {GOALS[name]}")
    lines.append(f"goal mosaic: {GOALS['mosaic']}")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "bench-scale.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines[-6:]))
    print(f"wrote {write_figures(os.path.join(args.out, 'bench-scale.json'), figures, views=args.views, seed=args.seed)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
