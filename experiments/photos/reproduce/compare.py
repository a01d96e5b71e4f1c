"""Does ``make train-sky-net`` reproduce the shipped sky network? (2026-12-05, session 15)

``python experiments/photos/reproduce/compare.py RETRAINED_DIR``

``RETRAINED_DIR`` holds ``sky_net.onnx`` and ``sky_net.json`` written by
``python -m skyrender.training.sky_net --steps 12000 --seed 1 --renders 0 --threads 1 --out RETRAINED_DIR/sky_net.onnx``
(the Makefile's command, PyTorch from the ``train`` extra). Compared with the shipped
``skyrender/features/weights/sky_net.{onnx,json}``: the files' bytes, the loss curve step by step, every weight
tensor of the two ONNX graphs, and the network's log-odds on the 31 dev photos.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys

import numpy as np

from skyrender.datasets.real_photos import items_on_side
from skyrender.features import load_photo
from skyrender.features.sky_net import WEIGHTS, sky_logits


def sha(path: str) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()[:16]


def initializers(path: str) -> dict[str, np.ndarray]:
    import onnx
    from onnx import numpy_helper

    return {t.name: numpy_helper.to_array(t) for t in onnx.load(path).graph.initializer}


def main() -> None:
    retrained = sys.argv[1]
    onnx_new, json_new = os.path.join(retrained, "sky_net.onnx"), os.path.join(retrained, "sky_net.json")
    json_old = os.path.join(os.path.dirname(WEIGHTS), "sky_net.json")
    print(f"onnx sha256: shipped {sha(WEIGHTS)}, retrained {sha(onnx_new)}, bytes equal: {sha(WEIGHTS) == sha(onnx_new)}")
    old, new = (json.load(open(p)) for p in (json_old, json_new))
    same_curve = [a["loss"] == b["loss"] for a, b in zip(old["curve"], new["curve"])]
    print(f"loss curve: {len(old['curve'])} / {len(new['curve'])} points, identical at {sum(same_curve)}; "
          f"final loss {old['curve'][-1]['loss']:.6f} / {new['curve'][-1]['loss']:.6f}; torch {old.get('torch')} / "
          f"{new.get('torch')}")
    try:
        a, b = initializers(WEIGHTS), initializers(onnx_new)
        diff = max(float(np.max(np.abs(a[k] - b[k]))) for k in a)
        print(f"weights: {len(a)} / {len(b)} tensors, same names {set(a) == set(b)}, largest difference {diff:.3g}")
    except ImportError:
        print("weights: onnx not installed, tensors not compared")
    worst = 0.0
    for it in items_on_side("dev"):
        image = load_photo(it.image_path)
        worst = max(worst, float(np.max(np.abs(sky_logits(image) - sky_logits(image, weights=onnx_new)))))
    print(f"log-odds on the 31 dev photos: largest difference {worst:.3g}")


if __name__ == "__main__":
    main()
