"""Learned per-pixel sky probability: a small fully convolutional network.

A U-Net of 230 k weights (``skyrender/features/weights/sky_net.onnx``,
trained by :mod:`skyrender.training.sky_net` on the training split of the
real photographs) maps a photo, reduced to
:data:`NET_WIDTH` pixels wide, to P(sky) per pixel. Inference runs in OpenCV's
DNN module on the CPU (already a dependency: no deep-learning stack to install).

Input channels (:func:`net_input`, shared with training): R, G, B scaled to about
[-2, 2], and the row's position in the frame, (v + 0.5) / h - 0.5.
"""

from __future__ import annotations

import os
from functools import lru_cache

import numpy as np

# photos are reduced to this width for the network (trained at 352-544 px). On the dev photos
# the hybrid extractor did better with the network narrower (mean within 5 px 92.8 / 93.9 /
# 95.1 % at 512 / 384 / 256 px), but 256 px did worse on the validation side (82.3 against
# 85.9 %, experiments/photos/probe-net-width-256.txt): a choice among six widths on 31 photos
# fitted their noise, so the network stays at 512 (a 256-px fit: skyline_fit --net-width 256)
NET_WIDTH = 512
STRIDE = 16  # the network's total down-sampling: input sides are multiples of it
WEIGHTS = os.path.join(os.path.dirname(__file__), "weights", "sky_net.onnx")


def net_size(width: int, height: int, net_width: int = NET_WIDTH) -> tuple[int, int]:
    """(w, h) of the network input for a ``width`` x ``height`` photo: ``net_width`` wide
    (never enlarged), the aspect kept to the nearest multiple of :data:`STRIDE`."""
    w = min(net_width, width)
    w = max(STRIDE, int(round(w / STRIDE)) * STRIDE)
    h = max(STRIDE, int(round(height * w / width / STRIDE)) * STRIDE)
    return w, h


def net_input(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(1, 4, h, w) float32 network input of an (H, W, 3) RGB uint8 photo at ``size`` = (w, h)."""
    import cv2

    w, h = size
    small = cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32)
    rgb = (small / 255.0 - 0.5) / 0.25
    row = np.broadcast_to(((np.arange(h, dtype=np.float32) + 0.5) / h - 0.5)[:, None, None], (h, w, 1))
    return np.ascontiguousarray(np.concatenate([rgb, row], axis=2).transpose(2, 0, 1)[None])


@lru_cache(maxsize=2)
def _load(path: str):
    import cv2

    if not os.path.exists(path):
        raise FileNotFoundError(f"sky network weights missing: {path} (make train-sky-net writes them)")
    return cv2.dnn.readNetFromONNX(path)


def sky_logits(image: np.ndarray, net_width: int = NET_WIDTH, weights: str = WEIGHTS) -> np.ndarray:
    """(h, w) float32 log-odds of sky at the network's resolution (see :func:`net_size`)."""
    size = net_size(image.shape[1], image.shape[0], net_width)
    net = _load(weights)
    net.setInput(net_input(image, size))
    return net.forward()[0, 0].astype(np.float32)
