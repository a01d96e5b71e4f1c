"""When do right answers come? The three-point search, chunk by chunk, on rendered views.

``python -m skyrender.diagnostics.search_rounds [--views N] [--set JSON] [--out F]``

Two sets of views, each rendered with known poses and localized with the render preset
(fov known, no prior), as the benchmarks draw them:

- ``tile``: ``make bench-scale``'s ``tile`` row (the whole SRTM3 tile N46E007, fov 35-60 deg,
  1008 x 756, the same seeds);
- ``synthetic``: ``make bench-localize``'s views (the 600² fractal DEM, 640 x 480, fov 60).

Per view: its error and the per-chunk trace of the search (``LocalizeStats.rounds``:
hypotheses solved, the best verified, trusted and refined three-point scores so far, the
refinements spent, whether a pose was accepted). It is the measured basis of the search's
stop rule (``LocalizeParams.stall_chunks``): how late right answers come, and how the
scores of views that end abstaining move. :func:`stop_point` replays a rule on a trace.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile

import numpy as np

from ..evaluate import REPO, provenance
from ..localizer.pipeline import search_stalled

TILE = os.path.join(REPO, "..", "shared", "data", "dem", "N46E007.hgt")


def stop_point(rounds: list[dict], stall_chunks: int, stall_gain: float) -> int | None:
    """How many chunks the search of this trace (run with the rule off) would have run under
    the stop rule (:func:`~skyrender.localizer.pipeline.search_stalled`), or None: all."""
    for i in range(1, len(rounds)):
        if rounds[i - 1]["accepted"]:
            return None  # from the first acceptance on, the confirming chunks decide
        if search_stalled(rounds[:i], stall_chunks, stall_gain):
            return i
    return None


def replay(rows: list[dict], stall_chunks: int, stall_gain: float) -> dict:
    """A stop rule replayed on traces run without it: chunks saved, and the views it would
    have lost (localized without it, stopped before the first acceptance or, for a view
    that was only localized by the final refinements, stopped at all)."""
    saved, lost = 0, []
    for r in rows:
        stop = stop_point(r["rounds"], stall_chunks, stall_gain)
        if stop is None:
            continue
        saved += len(r["rounds"]) - stop
        first = next((i for i, x in enumerate(r["rounds"]) if x["accepted"]), None)
        if r["status"] == "localized" and (first is None or stop <= first):
            lost.append(r["view"])
    return {"stall_chunks": stall_chunks, "stall_gain": stall_gain, "chunks": sum(len(r["rounds"]) for r in rows),
            "saved": saved, "lost": lost}


def tile_views(n: int, seed: int, tmp: str):
    """The ``tile`` row's model, terrain and views: (model, terrain, [(photo path, fov, pose)])."""
    from ..benchmarks.scale import render_views
    from ..dem import load_dem
    from ..model import cached_model, save_model
    from ..render import Terrain

    dem = load_dem(TILE)
    terrain = Terrain(dem)
    model = cached_model(dem, terrain=terrain)
    model_dir = os.path.join(tmp, "model")
    save_model(model, model_dir)
    views = render_views(TILE, model_dir, n, (35.0, 60.0), (1008, 756), tmp, seed)
    return model, terrain, [(v["photo"], v["fov"], np.asarray(v["pose"])) for v in views]


def synthetic_views(n: int, seed: int):
    """``make bench-localize``'s model, terrain and views (seed 1 there)."""
    from ..benchmarks.views import BENCH_FOV_DEG, bench_localize_views
    from ..dem.synthetic import fractal_terrain
    from ..model import build_model
    from ..render import Terrain

    dem = fractal_terrain()
    terrain = Terrain(dem)
    model = build_model(dem, terrain=terrain)
    _, sample, photos = bench_localize_views(terrain, model, n, seed)
    return model, terrain, [(photo, BENCH_FOV_DEG, pose.array()) for photo, pose in zip(photos, sample.poses)]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m skyrender.diagnostics.search_rounds",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--views", choices=["tile", "synthetic"], default="tile")
    parser.add_argument("-n", type=int, default=16, help="views")
    parser.add_argument("--seed", type=int, default=None, help="default: the benchmark's (tile 0, synthetic 1)")
    parser.add_argument("--set", default="{}", help="LocalizeParams fields as JSON (e.g. '{\"stall_chunks\": 0}')")
    parser.add_argument("--out", default=None, help="default experiments/scale/search-rounds-VIEWS.json")
    parser.add_argument("--replay", nargs="+", metavar="JSON", help="replay stop rules on traces written before "
                        "(run with stall_chunks 0) instead of localizing")
    args = parser.parse_args(argv)
    if args.replay:
        rows = []
        for path in args.replay:
            with open(path) as f:
                data = json.load(f)
            rows += [{**r, "view": f"{data['provenance'].get('views', '')}{r['view']}"} for r in data["rows"]]
        for k in (4, 6, 8, 10):
            for gain in (0.0, 0.05, 0.1):
                r = replay(rows, k, gain)
                print(f"stall_chunks {k:2d}, stall_gain {gain:.2f}: {r['saved']} of {r['chunks']} chunks saved; "
                      f"views lost {r['lost'] or 'none'}")
        return 0
    if args.views == "tile" and not os.path.exists(TILE):
        print(f"no DEM at {TILE}")
        return 2
    from ..benchmarks.scale import RIGHT_M
    from ..localizer import LocalizeParams, localize

    params = LocalizeParams.from_dict(json.loads(args.set))
    out = args.out or os.path.join(REPO, "experiments", "scale", f"search-rounds-{args.views}.json")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        if args.views == "tile":
            model, terrain, views = tile_views(args.n, 0 if args.seed is None else args.seed, tmp)
        else:
            model, terrain, views = synthetic_views(args.n, 1 if args.seed is None else args.seed)
        for i, (photo, fov, pose) in enumerate(views):
            result = localize(photo, model, 2.0, fov, terrain=terrain, params=params)
            error = float(np.hypot(*(result.pose[:2] - pose[:2]))) if result.localized else None
            rows.append({"view": i, "fov": fov, "status": result.status, "error_m": error,
                         "right": error is not None and error <= RIGHT_M, "seconds": round(result.seconds, 2),
                         "hypotheses": result.hypotheses, "rounds": result.stats.rounds})
            print(f"view {i:2d}: {result.status:<9} {'-' if error is None else f'{error:.0f} m':>8} "
                  f"{result.seconds:6.1f} s, {result.hypotheses} hypotheses", flush=True)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as f:
        json.dump({"provenance": provenance(views=args.views, params=json.loads(args.set)), "rows": rows}, f, indent=1)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
