"""Train the sky network of :mod:`skyrender.features.sky_net` and export it to ONNX.

``python -m skyrender.training.sky_net [--steps 12000] [--seed 1] [--threads 1] [--arch unet]`` (``make train-sky-net``)

The shipped weights (2026-12-04): 12,000 steps, seed 1, ~28 min on one core. The earlier 4,000 steps
underfitted (the network alone 86.2 % of its own training photos' columns within 5 px; 12,000: 91.8 %);
seeds 0 and 1 at 12,000 steps were both trained and seed 1 taken on the dev photos (network alone 91.7 /
91.8 % against 90.5 % at 4,000; hybrid 92.9 / 94.4 % against 92.8 %; ``experiments/photos/net-12k/``).

Data: the *training* side of the fixed split (``experiments/photos/split.json``: CH1
photos of the largest training place and web001-web034), with ``--dev-fold K ...`` the dev
photos of those folds (:func:`~skyrender.datasets.real_photos.dev_fold_of`: cross-fitting, a
network on both folds with its boundary search fitted on the output of two networks each trained
without one fold, ``skyline_fit --held-out-weights``; tried on 2026-12-03 and not shipped, see
``experiments/photos/README.md``), never the validation side; and, with
``--renders N``, renders with varied skies
(:func:`skyrender.training.synthetic_skies.training_renders`: sunset silhouettes,
overcast, haze, clouds on ridges, snow, power lines, occluders). The shipped weights use
none: 60 renders lowered the dev figures (mean within 5 px 78.6 against 86.0 %). Each step takes one picture at a
random width (352-544 px), flipped at
random, with random exposure, white balance, gamma, saturation and noise; the loss
is the binary cross-entropy at half resolution, weighted 5x within 3 px of the
boundary, and 0 where the truth is unknown (Web columns with no red mark).

``--arch`` picks the layout (:func:`build_model`); an image-level context and 1.5x the channels were
trained and did no better on dev (``experiments/photos/net-context/``).

Deterministic for a seed and thread count on one machine (PyTorch's CPU kernels). Writes
the ONNX weights and ``sky_net.json`` (seed, steps, data counts, loss curve) beside them.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from ..datasets.real_photos import items_in_dev_fold, items_on_side
from ..features.sky_net import STRIDE, WEIGHTS, net_input

TRAIN_WIDTHS = (352, 544)  # random input width per step (multiples of STRIDE)
PRELOAD_WIDTH = 640


ARCHITECTURES = ("unet", "unet-context", "unet-context-wide")


def build_model(arch: str = "unet"):
    """The network: a four-level U-Net, output P(sky) logits at half the input resolution.

    ``arch``: ``unet`` (the shipped weights); ``unet-context`` adds an image-level context
    (the deepest features averaged over the whole photo, mixed by a 1x1 convolution and added
    back at every position: whether a pale band is cloud or snow can depend on what lies far
    from it); ``unet-context-wide`` is that with 1.5x the channels at every level."""
    import torch
    from torch import nn

    if arch not in ARCHITECTURES:
        raise ValueError(f"unknown sky network architecture {arch!r} (one of {', '.join(ARCHITECTURES)})")
    k = 1.5 if arch.endswith("wide") else 1.0
    c1, c2, c3, c4, c0 = (int(round(c * k)) for c in (16, 32, 48, 64, 12))

    def block(i, o, stride=1, dilation=1):
        return nn.Sequential(nn.Conv2d(i, o, 3, stride=stride, padding=dilation, dilation=dilation), nn.ReLU())

    class SkyNet(nn.Module):
        def __init__(self):
            super().__init__()
            self.enc2 = nn.Sequential(block(4, c1, 2), block(c1, c1))  # 1/2
            self.enc4 = nn.Sequential(block(c1, c2, 2), block(c2, c2))  # 1/4
            self.enc8 = nn.Sequential(block(c2, c3, 2), block(c3, c3))  # 1/8
            self.ctx = nn.Sequential(block(c3, c4, 2), block(c4, c4, dilation=2), block(c4, c4, dilation=4))  # 1/16
            self.scene = (nn.Sequential(nn.AdaptiveAvgPool2d(1), nn.Conv2d(c4, c4, 1), nn.ReLU())
                          if arch != "unet" else None)
            self.dec8 = block(c4 + c3, c3)
            self.dec4 = block(c3 + c2, c2)
            self.dec2 = block(c2 + c1, c0)
            self.head = nn.Conv2d(c0, 1, 1)

        def forward(self, x):
            up = nn.functional.interpolate
            e2 = self.enc2(x)
            e4 = self.enc4(e2)
            e8 = self.enc8(e4)
            c = self.ctx(e8)
            if self.scene is not None:
                c = c + self.scene(c)
            d8 = self.dec8(torch.cat([up(c, scale_factor=2.0, mode="bilinear", align_corners=False), e8], 1))
            d4 = self.dec4(torch.cat([up(d8, scale_factor=2.0, mode="bilinear", align_corners=False), e4], 1))
            d2 = self.dec2(torch.cat([up(d4, scale_factor=2.0, mode="bilinear", align_corners=False), e2], 1))
            return self.head(d2)

    return SkyNet()


def _resize_width(image: np.ndarray, width: int) -> np.ndarray:
    import cv2

    h = int(round(image.shape[0] * width / image.shape[1]))
    return cv2.resize(image, (width, h), interpolation=cv2.INTER_AREA)


def load_training_set(renders: int, seed: int, dev_folds: tuple[int, ...] = ()) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(name, RGB uint8 image, P(sky) float32 with NaN = unknown) at :data:`PRELOAD_WIDTH`:
    the training side, plus the dev photos of ``dev_folds`` (cross-fitting:
    :func:`~skyrender.datasets.real_photos.dev_fold_of`)."""
    from ..features.photo_io import load_photo

    data = []
    for it in items_on_side("train") + [it for k in dev_folds for it in items_in_dev_fold(k)]:
        terrain = it.truth_mask()
        sky = np.where(terrain == 0.5, np.nan, 1.0 - terrain).astype(np.float32)
        data.append((it.key, _resize_width(load_photo(it.image_path), PRELOAD_WIDTH), _resize_width(sky, PRELOAD_WIDTH)))
    if renders:
        from .synthetic_skies import training_renders

        for name, image, sky in training_renders(renders, seed=seed):
            data.append((name, _resize_width(image, PRELOAD_WIDTH), _resize_width(sky.astype(np.float32), PRELOAD_WIDTH)))
    return data


def depth_below_skyline(sky: np.ndarray) -> np.ndarray:
    """(H, W) rows below the column's top terrain pixel (0 on it, negative above; a column with
    no terrain or unknown truth: +inf). ``sky``: P(sky), NaN unknown."""
    H = sky.shape[0]
    terrain = np.nan_to_num(sky, nan=1.0) < 0.5
    top = np.where(terrain.any(axis=0), np.argmax(terrain, axis=0), H).astype(np.float32)
    top[~np.isfinite(sky).all(axis=0)] = np.inf
    return np.arange(H, dtype=np.float32)[:, None] - top[None, :]


def recolour_regions(img: np.ndarray, sky: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Colour changes that keep the boundary where it is but take away colour as its cue
    (float RGB in [0, 1], ``sky`` P(sky) at the same size, NaN unknown): the terrain just below
    the skyline is blended toward the photo's sky colour (aerial haze) or toward white (snow
    fields, pale rock), fading with depth below the skyline over 20-200 px; or the sky is tinted
    (sunset, overcast). Far snowy or hazy ranges under a pale sky are what the network took for
    sky on unseen places."""
    out = img.copy()
    sky_px = np.nan_to_num(sky, nan=0.0) > 0.5
    kind = rng.integers(3)
    if kind < 2:
        depth = depth_below_skyline(sky)
        fade = np.exp(-np.clip(depth, 0, None) / rng.uniform(20, 200)) * (depth >= 0)
        if kind == 0 and sky_px.any():
            target = np.median(img[sky_px], axis=0)
        else:
            target = np.full(3, rng.uniform(0.8, 1.0)) * rng.uniform(0.93, 1.0, size=3)
        a = (rng.uniform(0.3, 0.85) * fade)[..., None]
        out = out * (1 - a) + target * a
    else:
        tint = rng.uniform(0.6, 1.2, size=3)
        grey = out.mean(axis=2, keepdims=True)
        toned = (grey + (out - grey) * rng.uniform(0.0, 1.0)) * tint
        out = np.where(sky_px[..., None], toned, out)
    return out


def swap_sky(image: np.ndarray, sky: np.ndarray, donor: np.ndarray, donor_sky: np.ndarray,
             max_stretch: float = 2.5) -> np.ndarray | None:
    """``image``'s sky (uint8 RGB; ``sky`` P(sky) at its size, NaN unknown) replaced by another photo's:
    the donor's band of rows that is sky in every column (above its highest terrain), resized to the
    image's width and stretched down to the image's lowest sky row, blended by P(sky) so the
    boundary's own mixed pixels stay mixed. Where the image's truth is unknown it is left as it is.
    None when the donor's clear band is too thin (stretched more than ``max_stretch`` times).

    Why: the training photos come from few places, each with its own sky; a cloud bank from one
    laid behind the ridges of another puts cumulus against snow and pale sky against hazy ranges in
    combinations the photos lack (unseen places' commonest misses, ``experiments/photos/sky-swap/``)."""
    import cv2

    H, W = sky.shape
    known = np.isfinite(sky)
    p = np.clip(np.nan_to_num(sky, nan=0.0), 0.0, 1.0)
    rows = np.flatnonzero((p > 0).any(axis=1))
    if len(rows) == 0:
        return None
    # the donor's rows that are sky in every column whose truth is known
    terrain_rows = np.flatnonzero((np.nan_to_num(donor_sky, nan=1.0) < 0.5).any(axis=1))
    clear_share = (terrain_rows[0] if len(terrain_rows) else donor_sky.shape[0]) / donor_sky.shape[0]
    donor = cv2.resize(donor, (W, int(round(donor.shape[0] * W / donor.shape[1]))), interpolation=cv2.INTER_AREA)
    band = int(clear_share * donor.shape[0]) - 1  # a row's margin: the boundary's mixed pixels stay out
    need = int(rows[-1]) + 1
    if band < 8 or need / band > max_stretch:
        return None
    fill = cv2.resize(donor[:band], (W, need), interpolation=cv2.INTER_LINEAR).astype(np.float32)
    out = image.astype(np.float32)
    a = np.where(known, p, 0.0)[:need, :, None]
    out[:need] = fill * a + out[:need] * (1 - a)
    return (out + 0.5).astype(np.uint8)


def augment(image: np.ndarray, sky: np.ndarray, rng: np.random.Generator, recolour: float = 0.0,
            donors: list | None = None, sky_swap: float = 0.0):
    """A random width, flip, exposure, white balance, gamma, saturation and noise; with
    probability ``recolour`` also :func:`recolour_regions`, with probability ``sky_swap`` the sky
    of one of ``donors`` ((image, P(sky)) pairs) laid in (:func:`swap_sky`). Each is drawn from
    ``rng`` only when its option is on, so with both 0 it draws exactly what it did before the
    options existed."""
    import cv2

    if sky_swap and donors and rng.random() < sky_swap:
        donor, donor_sky = donors[int(rng.integers(len(donors)))]
        swapped = swap_sky(image, sky, donor, donor_sky)
        if swapped is not None:
            image = swapped
    lo, hi = TRAIN_WIDTHS
    w = int(rng.integers(lo // STRIDE, hi // STRIDE + 1)) * STRIDE
    h = max(STRIDE, int(round(image.shape[0] * w / image.shape[1] / STRIDE)) * STRIDE)
    img = cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
    lab = cv2.resize(np.nan_to_num(sky, nan=-1.0), (w // 2, h // 2), interpolation=cv2.INTER_AREA)
    known = cv2.resize(np.isfinite(sky).astype(np.float32), (w // 2, h // 2), interpolation=cv2.INTER_AREA) > 0.999
    if rng.random() < 0.5:
        img, lab, known = img[:, ::-1], lab[:, ::-1], known[:, ::-1]
    if recolour and rng.random() < recolour:
        img = recolour_regions(img, cv2.resize(np.where(known, lab, np.nan), (w, h), interpolation=cv2.INTER_NEAREST), rng)
    grey = img.mean(axis=2, keepdims=True)
    img = grey + (img - grey) * rng.uniform(0.6, 1.4)  # saturation
    img = img * rng.uniform(0.85, 1.15, size=3) * rng.uniform(0.7, 1.3)  # white balance, exposure
    img = np.clip(img, 0, 1) ** rng.uniform(0.7, 1.4)
    img = img + rng.normal(0, rng.uniform(0, 0.02), img.shape)
    img = (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8)
    return np.ascontiguousarray(img), np.ascontiguousarray(lab), np.ascontiguousarray(known)


def boundary_weight(sky: np.ndarray, known: np.ndarray, reach: int = 3, gain: float = 4.0) -> np.ndarray:
    """Per-pixel loss weight: 1 + ``gain`` within ``reach`` px of a sky/terrain change; 0 unknown."""
    import cv2

    hard = (sky > 0.5).astype(np.uint8)
    edge = cv2.morphologyEx(hard, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8))
    near = cv2.dilate(edge, np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) > 0
    return np.where(known, 1.0 + gain * near, 0.0).astype(np.float32)


def train(steps: int, seed: int, renders: int, out: str = WEIGHTS, log_every: int = 100, threads: int = 2,
          dev_folds: tuple[int, ...] = (), recolour: float = 0.0, arch: str = "unet", sky_swap: float = 0.0) -> dict:
    import torch

    torch.manual_seed(seed)
    torch.set_num_threads(threads)
    rng = np.random.default_rng(seed)
    data = load_training_set(renders, seed, dev_folds)
    donors = [(image, sky) for _, image, sky in data]
    model = build_model(arch)
    opt = torch.optim.Adam(model.parameters(), lr=2e-3)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=2e-3, total_steps=steps, pct_start=0.1)
    losses, curve, t0 = [], [], time.perf_counter()
    for step in range(steps):
        _, image, sky = data[int(rng.integers(len(data)))]
        img, lab, known = augment(image, sky, rng, recolour, donors, sky_swap)
        x = torch.from_numpy(net_input(img, (img.shape[1], img.shape[0])))
        y = torch.from_numpy(np.clip(lab, 0, 1))[None, None]
        wgt = torch.from_numpy(boundary_weight(lab, known))[None, None]
        logits = model(x)
        per_pixel = torch.nn.functional.binary_cross_entropy_with_logits(logits, y, reduction="none")
        loss = (per_pixel * wgt).sum() / wgt.sum().clamp(min=1)
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        losses.append(loss.item())
        if (step + 1) % log_every == 0:
            curve.append({"step": step + 1, "loss": float(np.mean(losses[-log_every:])),
                          "seconds": round(time.perf_counter() - t0, 1)})
            print(f"step {step + 1:5d}  loss {curve[-1]['loss']:.4f}  {curve[-1]['seconds']:.0f} s", flush=True)
    model.eval()
    os.makedirs(os.path.dirname(out), exist_ok=True)
    example = torch.zeros(1, 4, 256, 512)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(model, example, out, dynamo=False, input_names=["x"], output_names=["logits"],
                          dynamic_axes={"x": {2: "h", 3: "w"}, "logits": {2: "h2", 3: "w2"}}, opset_version=17)
    log = {"seed": seed, "steps": steps, "renders": renders, "threads": threads, "photos": len(data) - renders,
           "dev_folds": list(dev_folds), "recolour": recolour, "sky_swap": sky_swap, "arch": arch,
           "train_widths": TRAIN_WIDTHS, "torch": torch.__version__, "curve": curve,
           "seconds": round(time.perf_counter() - t0, 1)}
    with open(os.path.splitext(out)[0] + ".json", "w") as f:
        json.dump(log, f, indent=1)
    return log


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=12000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--renders", type=int, default=0,
                        help="synthetic training renders with varied skies (60 lowered the dev figures: 78.6 against 86.0 %%)")
    parser.add_argument("--threads", type=int, default=1, help="PyTorch CPU threads (results depend on it)")
    parser.add_argument("--dev-fold", type=int, nargs="*", default=[],
                        help="also train on these folds of the dev photos (cross-fitting; the others stay unseen)")
    parser.add_argument("--recolour", type=float, default=0.0,
                        help="share of steps whose terrain near the skyline is hazed or whitened, or whose sky is tinted")
    parser.add_argument("--sky-swap", type=float, default=0.0,
                        help="share of steps whose sky is another training photo's (swap_sky)")
    parser.add_argument("--arch", choices=ARCHITECTURES, default="unet",
                        help="the network's layout (unet: the shipped weights; see build_model)")
    parser.add_argument("--out", default=WEIGHTS)
    args = parser.parse_args(argv)
    log = train(args.steps, args.seed, args.renders, args.out, threads=args.threads, dev_folds=tuple(args.dev_fold),
                recolour=args.recolour, arch=args.arch, sky_swap=args.sky_swap)
    print(f"wrote {args.out} ({log['photos']} photos, {log['renders']} renders, {log['seconds']:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
