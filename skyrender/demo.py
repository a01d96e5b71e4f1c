"""``make demo``: render a view of a real DEM and write it with its skyline drawn on.

Usage: ``python -m skyrender.demo SCENE.toml [--out DIR]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from .errors import InputError


def run_demo(scene_path: str, out_dir: str) -> int:
    from .io import save_skyline
    from .render import Terrain
    from .render.photo import Look, render_photo
    from .scenes import load_scene
    from .viz import draw_skyline, write_image

    os.makedirs(out_dir, exist_ok=True)
    t0 = time.perf_counter()
    scene = load_scene(scene_path)
    print(scene.dem.describe())
    t1 = time.perf_counter()
    terrain = Terrain(scene.dem)
    t2 = time.perf_counter()
    print(f"terrain scene built in {t2 - t1:.2f} s ({terrain.variant}); DEM loaded in {t1 - t0:.2f} s")
    for view in scene.views:
        t3 = time.perf_counter()
        photo = render_photo(terrain, view.pose, view.intrinsics, Look())
        t4 = time.perf_counter()
        base = os.path.join(out_dir, view.name)
        write_image(base + ".png", photo.image)
        write_image(base + "_skyline.png", draw_skyline(photo.image, photo.skyline))
        save_skyline(base + "_skyline.npy", photo.skyline)
        p = view.pose
        print(f"view {view.name}: x={p.x:.1f} y={p.y:.1f} z={p.z:.1f} pan={p.pan:.1f} tilt={p.tilt:.1f} "
              f"swing={p.swing:.1f} fov={view.intrinsics.fov:.1f}; rendered in {t4 - t3:.2f} s")
        print(f"  wrote {base}.png and {base}_skyline.png")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m skyrender.demo", description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--out", default="out")
    args = parser.parse_args(argv)
    try:
        return run_demo(args.scene, args.out)
    except InputError as exc:
        print(f"skyrender: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
