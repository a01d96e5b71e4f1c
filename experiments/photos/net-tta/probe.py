"""Test-time augmentation of the sky network, a probe on the dev photos (2026-12-05, session 15).

``python experiments/photos/net-tta/probe.py OUT.json [--side dev] [--variants shipped flip ...]``

The network was trained on pictures flipped at random and 352-544 px wide; averaging its log-odds over the photo
and its mirror image, or over two input widths, costs one or two more passes of a 0.04-s network. Each variant
replaces :func:`skyrender.features.sky_net.sky_logits` for the whole extractor (the network's boundary search,
the hybrid's seeds, the column confidence, ``select``'s choice) and extracts every photo of a side with
``hybrid`` and ``select``; printed per variant: photos meeting the target, mean share of columns within 5 px.
"""

from __future__ import annotations

import argparse
import json

import cv2
import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo, sky_net
from skyrender.features import skyline as skyline_module

SHIPPED = sky_net.sky_logits


def averaged(widths: tuple[int, ...], flip: bool):
    """A ``sky_logits`` averaging the shipped network's log-odds over input ``widths`` (each resized to the
    first width's grid) and, with ``flip``, the mirrored photo too."""

    def logits(image, net_width=sky_net.NET_WIDTH, weights=sky_net.WEIGHTS):
        base = SHIPPED(image, widths[0], weights)
        h, w = base.shape
        acc, n = np.zeros_like(base), 0
        for width in widths:
            for mirrored in ((False, True) if flip else (False,)):
                im = image[:, ::-1] if mirrored else image
                out = SHIPPED(np.ascontiguousarray(im), width, weights)
                out = out[:, ::-1] if mirrored else out
                acc += out if out.shape == base.shape else cv2.resize(out, (w, h), interpolation=cv2.INTER_LINEAR)
                n += 1
        return acc / n

    return logits


VARIANTS = {"shipped": None, "flip": ((512,), True), "widths 384+512": ((512, 384), False),
            "flip + widths 384+512": ((512, 384), True), "widths 448+512+576": ((512, 448, 576), False)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--side", default="dev")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS))
    args = ap.parse_args()
    items = items_on_side(args.side)
    photos = [(it.key, load_photo(it.image_path), it.truth_skyline()) for it in items]
    results = {}
    for name in args.variants:
        spec = VARIANTS[name]
        skyline_module.sky_logits = SHIPPED if spec is None else averaged(*spec)
        rows = []
        for key, image, truth in photos:
            row = {"photo": key}
            for method in ("hybrid", "select"):
                e = column_errors(extract_skyline(image, SkylineParams(method=method)).skyline, truth)
                row[method] = {"median": float(np.median(e)), "within5": float(np.mean(e <= 5.0))}
            rows.append(row)
        results[name] = rows
        for method in ("hybrid", "select"):
            met = sum(meets_target(r[method]["median"], r[method]["within5"]) for r in rows)
            mean = 100 * np.mean([r[method]["within5"] for r in rows])
            print(f"{args.side} {name:24s} {method:6s} met {met:3d} of {len(rows)}  mean within 5 px {mean:.1f} %",
                  flush=True)
    with open(args.out, "w") as f:
        json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
