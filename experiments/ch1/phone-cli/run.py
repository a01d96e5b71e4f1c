"""CH1 photos as a phone hands them over, localized by the command a user types (2026-12-05, session 15).

``python experiments/ch1/phone-cli/run.py OUT.json [--folder] KEY ...``

Each photo is scaled up 4x (:func:`~skyrender.benchmarks.real_localize.photo_scaled_up`: 4096 px wide, 11-12.6 MP),
stored as a JPEG turned on its side with EXIF Orientation 6 (upright once the orientation is applied) and
``FocalLengthIn35mmFilm`` from its true fov in whole millimetres, as a camera writes it. Then, as a user would::

    skyrender localize PHOTO.jpg --dem TILE,TILE,... --dem-bounds W,S,E,N --height 2 --json --stats

with the SRTM3 tiles around the place (``--folder``: ``--dem`` the whole ``../shared/data/dem``, tiles of other kinds
and places included, as a user would pass it) and its search window (``real_localize.place_window``), no ``--fov``: twice, the
first with an empty model cache (the model built as a new user waits), the second with it. Per run: the wall seconds
and peak RSS of the command's own process (``scale.run_measured``), the command's ``seconds``, the status, confidence,
fov, and the error to the true position.
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile

import numpy as np

from skyrender.benchmarks.real_localize import photo_scaled_up, place_window, places_of
from skyrender.benchmarks.scale import run_measured, skyrender_command, stats_line
from skyrender.datasets.real_photos import items_on_side
from skyrender.diagnostics.oracle import DEM_DIR, tiles_around
from skyrender.evaluate import git_commit
from skyrender.features.photo_io import DIAGONAL_35MM


def phone_jpeg(path: str, upright: np.ndarray, fov_deg: float) -> int:
    """Write ``upright`` (RGB) as a JPEG stored turned 90 degrees with EXIF Orientation 6 and a 35 mm-equivalent
    focal length for ``fov_deg`` (horizontal), rounded to a millimetre; that focal length."""
    from PIL import ExifTags, Image

    H, W = upright.shape[:2]
    f_px = W / (2.0 * math.tan(math.radians(fov_deg) / 2.0))
    f35 = int(round(f_px * DIAGONAL_35MM / math.hypot(W, H)))
    im = Image.fromarray(np.ascontiguousarray(np.rot90(upright, 1)))  # Orientation 6: turn 90 deg clockwise to view
    exif = im.getexif()
    exif[0x0112] = 6
    exif.get_ifd(ExifTags.IFD.Exif)[0xA405] = f35
    im.save(path, exif=exif, quality=92)
    return f35


def main() -> None:
    from pyproj import Geod

    out_path, keys = sys.argv[1], [k for k in sys.argv[2:] if k != "--folder"]
    folder = "--folder" in sys.argv[2:]
    items = {it.key: it for side in ("train", "dev", "validation") for it in items_on_side(side) if it.key.startswith("ch1/")}
    place_of, centres = places_of(items.values())
    geod = Geod(ellps="WGS84")
    records = []
    with tempfile.TemporaryDirectory() as tmp:
        for key in keys:
            it = items[key]
            _, big, fov = photo_scaled_up(it, 4)
            photo = os.path.join(tmp, key.replace("/", "_") + ".jpg")
            f35 = phone_jpeg(photo, big, fov)
            lat0, lon0 = centres[place_of[key]]
            west, south, east, north = place_window(lat0, lon0)
            cache = os.path.join(tmp, "cache-" + place_of[key].replace("/", "_"))
            dem = DEM_DIR if folder else ",".join(tiles_around(lat0, lon0))
            args = skyrender_command("localize", photo, "--dem", dem, "--dem-bounds",
                                     f"{west},{south},{east},{north}", "--height", "2", "--json", "--stats")
            for run in ("fresh model cache", "model cached"):
                os.environ["SKYRENDER_CACHE"] = cache
                r = run_measured(args)
                doc = json.loads(r["stdout"]) if r["stdout"].strip() else {}
                stats = stats_line(r["stderr"])
                error = (geod.inv(it.lon, it.lat, doc["lon"], doc["lat"])[2] if doc.get("status") == "localized"
                         else None)
                rec = {"photo": key, "run": run, "size": f"{big.shape[1]}x{big.shape[0]}", "f35_mm": f35,
                       "true_fov": fov, "exit": r["status"], "status": doc.get("status"), "fov": doc.get("fov"),
                       "confidence": doc.get("confidence"), "error_m": error, "command_s": doc.get("seconds"),
                       "wall_s": r["wall_s"], "peak_gb": r["peak_gb"], "searched_width": stats.get("searched_width"),
                       "stderr_tail": r["stderr"].strip().splitlines()[-1:] if r["status"] not in (0, 3) else []}
                records.append(rec)
                err = "-" if error is None else f"{error:.0f} m"
                print(f"{key} {rec['size']} EXIF {f35} mm ({fov:.2f} deg), {run}: exit {r['status']}, {rec['status']}, "
                      f"error {err}, confidence {rec['confidence']}, fov {rec['fov']}, command {rec['command_s']} s, "
                      f"wall {r['wall_s']:.1f} s, peak {r['peak_gb']:.2f} GB, searched width {rec['searched_width']}",
                      flush=True)
    with open(out_path, "w") as f:
        json.dump({"commit": git_commit(), "runs": records}, f, indent=1)


if __name__ == "__main__":
    main()
