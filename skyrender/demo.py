"""``make demo``: render a view of a real DEM, localize it with no prior, print the
position and orientation errors, and write the overlay picture.

Usage: ``python -m skyrender.demo SCENE.toml [--out DIR]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from .errors import InputError
from .evaluate import angle_differences, position_errors


def run_demo(scene_path: str, out_dir: str) -> int:
    from .localizer import localize
    from .model import build_model
    from .render import Terrain
    from .render.photo import Look, render_photo
    from .scenes import load_scene
    from .viz import draw_skyline, localization_overlay, write_image

    os.makedirs(out_dir, exist_ok=True)
    t0 = time.perf_counter()
    scene = load_scene(scene_path)
    print(scene.dem.describe())
    terrain = Terrain(scene.dem)
    model = build_model(scene.dem, terrain=terrain)
    print(f"{model.summary()}; scene + model ready in {time.perf_counter() - t0:.1f} s ({terrain.variant})")
    worst = 0
    for view in scene.views:
        photo = render_photo(terrain, view.pose, view.intrinsics, Look())
        base = os.path.join(out_dir, view.name)
        write_image(base + ".png", photo.image)
        write_image(base + "_skyline.png", draw_skyline(photo.image, photo.skyline))
        p = view.pose
        print(f"view {view.name}: rendered from x={p.x:.1f} y={p.y:.1f} z={p.z:.1f} pan={p.pan:.2f} "
              f"tilt={p.tilt:.2f} swing={p.swing:.2f} fov={view.intrinsics.fov:.1f}")
        result = localize(photo.image, model, view.height_above_ground, view.intrinsics.fov, terrain=terrain)
        write_image(base + "_localized.png", localization_overlay(photo.image, result, model))
        if not result.localized:
            print(f"  abstained after {result.hypotheses} hypotheses ({result.seconds:.1f} s)")
            worst = 3
            continue
        est = result.pose
        truth = p.array()
        d_pos = float(position_errors(est, truth)[0])
        d_ang = np.abs(angle_differences(est[3:], truth[3:]))
        print(f"  localized: x={est[0]:.1f} y={est[1]:.1f} z={est[2]:.1f} pan={est[3]:.2f} tilt={est[4]:.2f} "
              f"swing={est[5]:.2f}; confidence {result.confidence:.2f}; {result.hypotheses} hypotheses, "
              f"{result.seconds:.1f} s")
        print(f"  error: position {d_pos:.1f} m (height {abs(est[2] - truth[2]):.1f} m), pan {d_ang[0]:.3f} deg, "
              f"tilt {d_ang[1]:.3f} deg, swing {d_ang[2]:.3f} deg")
        print(f"  wrote {base}.png and {base}_localized.png (red: photo skyline, green: rendered from the "
              f"estimate, yellow: model peaks on it)")
    return worst


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
