"""Stage 2a — skyline extraction from a photograph (``skyrender skyline``).

0. Thin dark cables across the sky (power lines, lift cables) are painted over
   (:mod:`.cables`): both extractors took the first one for the skyline.
1. Per-pixel sky probability: by default (``method="gmm"``) from colour-texture
   mixtures fitted to this photo's sky and terrain, re-fitted from each boundary
   estimate (:mod:`.sky`); with ``method="net"`` from a small fully convolutional
   network trained on real photos (:mod:`.sky_net`); with ``method="hybrid"`` the
   network's boundary seeds one round of the colour-texture mixtures, whose evidence
   is added to the network's.
2. A global optimum over columns (dynamic programming): one boundary row
   per column minimising misclassified pixels, minus a bonus for a colour
   edge at the boundary, plus a truncated-linear penalty on jumps between
   neighbouring columns (poles and cliffs may jump, noise may not).
3. Sub-pixel refinement from the colour profile across the boundary, and a
   per-column confidence: the probability margin times the colour contrast, or, with
   the network, a logistic model of "within 5 px of the truth" on those and the
   boundary's roughness, fitted on the dev photos (``weights/sky_net_fit.json``).
4. With ``method="select"`` both ``hybrid`` and ``gmm`` run (with ``select_gmm_above``
   set, ``gmm`` only where the hybrid doubts more than that share of its columns:
   :func:`hybrid_in_doubt`), and where their skylines part, the one more confident over
   the disputed columns is kept (:func:`select_skylines`): they fail on different photos.

Photos wider than :attr:`SkylineParams.work_width` (a 12-megapixel phone photo) are
processed on a copy reduced to :attr:`SkylineParams.reduced_width`; the boundary is then refined at full resolution in a
band around it, and returned in full-image coordinates.

Output per README, Conventions: v per column (u = i + 0.5); NaN where a column sees
only sky; 0 where terrain reaches the top edge.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..blocks import Once, concurrently, one_thread
from .cables import CableParams, remove_cables
from .sky import GMM_TOL, MIXTURE_SAMPLES, pixel_features, sky_probability
from .sky_net import NET_WIDTH, sky_logits

FITTED = os.path.join(os.path.dirname(__file__), "weights", "sky_net_fit.json")  # by skyrender.training.skyline_fit


def fitted_path(net_width: int = NET_WIDTH, net_weights: str | None = None) -> str:
    """Where the boundary weights and column confidence fitted for a network ``net_width`` px
    wide are kept: ``sky_net_fit.json`` for the default width, ``sky_net_fit-<width>.json`` else;
    for another network's ONNX file (``net_weights``), ``<its name>_fit.json`` beside it."""
    base = FITTED if net_weights is None else os.path.splitext(net_weights)[0] + "_fit.json"
    return base if net_width == NET_WIDTH else base.replace(".json", f"-{net_width}.json")


@dataclass(frozen=True)
class SkylineParams:
    # "gmm": per-photo colour mixtures (default: it also holds on renders); "net": the learned
    # sky probability (4x faster than gmm, not trained on renders); "hybrid": the network's boundary
    # seeds per-photo mixtures (0.3 s); "select": hybrid and gmm both, and where they part, the one
    # more confident on the disputed columns (:func:`select_skylines`; best on unseen real photos, 0.4 s a
    # 1024-wide photo, the two on a thread each; with ``select_gmm_above`` gmm only where the hybrid doubts)
    method: str = "gmm"
    jump_cost: float = 0.25  # per pixel of boundary jump between columns
    jump_cap: float = 12.0  # no jump costs more than this (vertical edges)
    edge_bonus: float = 16.0  # weight of the colour edge at the boundary
    edge_percentile: float = 97.0  # edges this strong or stronger count fully (1.0)
    # the same three with the network's probability; None: as fitted on the dev photos
    net_edge_bonus: float | None = None
    net_jump_cost: float | None = None
    net_jump_cap: float | None = None
    # the sky network's input width (px; the photo is reduced to it, never enlarged)
    net_width: int = NET_WIDTH
    # another sky network's ONNX file (its fit in <name>_fit.json beside it); None: the shipped one
    net_weights: str | None = None
    # wider photos are processed on a reduced copy; the boundary search's weights are in pixels,
    # so both extractors are scale-sensitive (gmm's were set on 1388-wide photos)
    work_width: int = 1600
    # ... this wide (at most work_width): on the 31 dev photos up-scaled 4x (11-13 MP), the hybrid met the target on 19 at
    # 1024 and at 1600, mean within 5 px 92.8 against 92.3 %, in 0.95 against 1.85 s (experiments/photos/README.md)
    reduced_width: int = 1024
    components: int = 5  # Gaussian components per class in the colour-texture mixtures
    rounds: int = 3  # boundary estimate -> re-fit colour models -> boundary
    band: int = 6  # pixels either side of the boundary left out of re-fitting
    texture_weight: float = 0.3  # textured pixels are unlikely sky
    # gmm: the rounds before the last on every n-th row and column, fitted on this many pixels (1: off),
    # for photos at least draft_min_width px wide (a 320-px render's 160-px draft put a near slope's
    # training pixels wrong: 58 % within 5 px instead of 70+); on the 31 dev photos 2 met the target
    # on 18 (1: 17), mean within 5 px 85.6 % (84.3 %), in 3.05 s a photo (5.01 s):
    # experiments/photos/probe-gmm-draft2.txt
    draft_scale: int = 2
    draft_samples: int = 4_000
    draft_min_width: int = 640
    # thin dark cables across the sky are painted over first (:mod:`.cables`); None: left as they are
    cables: CableParams | None = CableParams()
    # "select": hybrid and gmm part ways where their skylines lie more than this apart (px)
    select_tol_px: float = 5.0
    # "select": gmm runs only where more than this share of the hybrid's columns have confidence below 0.5, the
    # hybrid's skyline kept as it is on the others; 0: gmm always (the default). An option for speed: at 0.02 gmm
    # runs on a third of the photos and select took 0.38 s a photo (median) instead of 0.72 s (before session 31's
    # same-values speed-ups, experiments/photos/same-values-faster/); chosen on the dev
    # and training photos (target met on 24 / 58 against 23 / 59), but on the validation side 46 of 80 photos meet
    # the target against 48, and one CH1 right answer loses its confidence (experiments/photos/select-gate/).
    # A localization takes 12-30 s: the fraction of a second is not worth it there.
    select_gmm_above: float = 0.0
    # gmm: the colour edge counts at a boundary only as far as P(sky) changes across it (|mean over the 2 rows above
    # - the 2 below| times this, at most 1; 0: edges count wherever they are). Off by default: it stops a faint edge
    # inside a slope from pulling the boundary under a thin band of it (the slope render of issue 18: 17 px -> 0),
    # and on the training side select met the target on 24 / 59 dev / train photos against 23 / 59 (mean within 5 px
    # 95.4 / 94.7 against 95.2 / 94.4 %); but on renders it loses foreground occluders (99.7 -> 80 % within 5 px), and as
    # the default it would move every gmm line and the localizer's figures (experiments/photos/quick-checks-2026-12-05/)
    edge_contrast: float = 0.0
    # the colour mixtures' EM budget (None: the method's, :meth:`mixture_budget`): the EM stops when the mean
    # log-likelihood changes by less than ``mixture_tol``, and the full-resolution fits sample ``mixture_samples``
    # pixels a class (gmm's drafts keep ``draft_samples``)
    mixture_tol: float | None = None
    mixture_samples: int | None = None

    def mixture_budget(self) -> tuple[float, int]:
        """(tol, samples) of the colour mixtures' EM: ``mixture_tol`` and ``mixture_samples``, where None the
        method's. "select", the photo extractor, stops at 1e-2 on 6,000 pixels: 0.78x its seconds, the same
        training-side skylines and localizations, chosen there (``experiments/photos/em-budget/``). The others keep
        scikit-learn's 1e-3 and 12,000, which the render preset and gmm's hand-set checks stand on: with 1e-2 a
        rendered view with a fifth of its columns occluded lost its answer, and the weisshorn photo's hazy ridge 2
        of its 16 columns."""
        tol, samples = SELECT_MIXTURE_BUDGET if self.method == "select" else (GMM_TOL, MIXTURE_SAMPLES)
        return (tol if self.mixture_tol is None else self.mixture_tol,
                samples if self.mixture_samples is None else self.mixture_samples)


#: (tol, samples) of the colour mixtures' EM for ``method="select"`` (:meth:`SkylineParams.mixture_budget`)
SELECT_MIXTURE_BUDGET = (1e-2, 6_000)


@dataclass(frozen=True)
class ExtractedSkyline:
    """skyline (W,) v per column; confidence (W,) in [0, 1]; sky_probability (H, W)."""

    skyline: np.ndarray
    confidence: np.ndarray
    sky_probability: np.ndarray


def boundary_dp(cost: np.ndarray, jump_cost: float, jump_cap: float) -> np.ndarray:
    """Minimum-cost path through a (H+1, W) cost array, one row index per column.

    Transition cost between columns: min(jump_cost * |b - b'|, jump_cap). The
    min-convolution uses running minima, so each column costs O(H). Compiled
    (:func:`skyrender.features.boundary_kernel.boundary_path`, numba): numpy's
    operations column by column, the same path to the bit, 6x faster than ~20 numpy calls a column.
    """
    from .boundary_kernel import boundary_path  # numba: imported, and compiled or loaded from its cache, on first use

    n = cost.shape[0]
    return boundary_path(np.ascontiguousarray(cost.T, dtype=np.float64), jump_cost * np.arange(n, dtype=np.float64),
                         float(jump_cap))


def _edge_strength(features: np.ndarray, percentile: float) -> np.ndarray:
    """(H+1, W) colour-edge strength between rows b-1 and b, in [0, 1].

    Lab distance of the two rows above from the two rows below, divided by its
    ``percentile`` over the image: a moderate scale (rather than the very strongest
    edges') keeps a faint snow/sky boundary worth almost as much as a hard
    snow/rock edge further down, which would otherwise pull the boundary below it.
    """
    H, W = features.shape[:2]
    e = np.zeros((H + 1, W))
    pad = np.empty((H + 4, W))  # a channel, its first and last rows repeated twice
    for c in range(3):  # channel by channel, in place: 0.7x the time of whole (H, W, 3) arrays, the same values
        pad[2 : H + 2] = features[..., c]
        pad[:2], pad[H + 2 :] = pad[2], pad[H + 1]
        above = pad[0 : H + 1] + pad[1 : H + 2]  # rows b-2, b-1
        above *= 0.5
        below = pad[2 : H + 3] + pad[3 : H + 4]  # rows b, b+1
        below *= 0.5
        above -= below
        above *= above
        e += above  # the squares summed in channel order, as np.linalg.norm does
    np.sqrt(e, out=e)
    e[0] = e[-1] = 0.0
    scale = max(np.percentile(e, percentile), 1.0)
    e /= scale
    return np.clip(e, 0, 1, out=e)


def _row_prior(H: int) -> np.ndarray:
    """P(sky) by row: likely at the top, unlikely at the bottom, neutral in between."""
    v = (np.arange(H) + 0.5) / H
    return 0.5 + 0.35 * np.tanh((0.5 - v) * 3.0)


def _subpixel(features: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Refine integer boundaries: the sky coverage of the pixels around each boundary,
    measured along the colour axis from terrain to sky, sums to the boundary offset.

    The window is 3 rows either side and the refinement may move a boundary by up to
    2 rows: a strong edge saturates the edge term over two neighbouring rows, so the
    integer boundary can sit one row off the colour transition.
    """
    H, W = features.shape[:2]
    cols = np.arange(W)
    k = 3

    def lab_at(r):  # (n, W, 3) float64 Lab at rows r (n, W) of each column: gathered, then cast, not the whole photo
        return features[r, cols[None, :], :3].astype(np.float64)

    def rows_mean(offsets):
        return lab_at(np.clip(rows[None, :] + np.array(offsets)[:, None], 0, H - 1)).mean(axis=0)

    sky = rows_mean([-5, -4, -3])
    ter = rows_mean([2, 3, 4])
    axis = sky - ter
    norm2 = np.maximum(np.sum(axis**2, axis=1), 1e-9)
    offsets = np.arange(-k, k)
    r = np.clip(rows[None, :] + offsets[:, None], 0, H - 1)
    s = np.sum((lab_at(r) - ter[None]) * axis[None], axis=2) / norm2[None]
    coverage = np.clip(s, 0, 1).sum(axis=0)
    refined = rows - k + coverage
    contrast = np.sqrt(norm2)
    ok = (rows > k) & (rows < H - k) & (contrast > 2.0)
    return np.where(ok, np.clip(refined, rows - 2.0, rows + 2.0), rows.astype(np.float64)), contrast


def _top_components(features: np.ndarray, labels: np.ndarray, max_lab_distance: float = 15.0):
    """Labels of the smooth components that touch the top edge: (sky-like, others).

    A near slope reaching the top of the frame is smooth and touches the top edge too:
    only the component that covers most of the top row, and others of a similar mean
    Lab colour (within ``max_lab_distance``), are taken for sky; the others are terrain.
    A component that also reaches the bottom fifth of the frame is the slope, not the sky,
    whatever share of the top row it covers (a camera facing a slope that fills most of the
    top edge), unless every one does.
    """
    top, counts = np.unique(labels[0][labels[0] > 0], return_counts=True)
    if len(top) <= 1:
        return top, top[:0]
    from scipy import ndimage

    boxes = ndimage.find_objects(labels)  # one per label 1..max (None for a label not present)
    above_bottom_fifth = np.array([boxes[t - 1][0].stop <= int(0.8 * labels.shape[0]) for t in top])
    if above_bottom_fifth.any():
        counts = np.where(above_bottom_fifth, counts, -1)
    lab = features[..., :3]
    means = np.stack([ndimage.mean(lab[..., c], labels, top) for c in range(3)], axis=1)
    sky_like = np.linalg.norm(means - means[np.argmax(counts)], axis=1) <= max_lab_distance
    return top[sky_like], top[~sky_like]


def _eroded(mask: np.ndarray, steps: int) -> np.ndarray:
    """(H, W) bool: ``mask`` eroded ``steps`` times by the 4-neighbour cross, outside the frame counting as False,
    as ``scipy.ndimage.binary_erosion(mask, iterations=steps)`` gives it, in one pass of OpenCV's erosion by the
    diamond the crosses add up to (30x faster on a 1024-wide photo)."""
    import cv2

    r = np.abs(np.arange(-steps, steps + 1))
    diamond = (r[:, None] + r[None, :] <= steps).astype(np.uint8)
    out = cv2.erode(np.ascontiguousarray(mask, dtype=bool).view(np.uint8), diamond,
                    borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return out.view(bool)


def initial_seeds(features: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First-round training pixels: sky = the smooth region connected to the top edge
    (sky is the smoothest thing that touches the top of a landscape photo); terrain =
    the textured pixels, smooth slopes of another colour touching the top, and the
    bottom fifth of the frame, below every sky seed."""
    from scipy import ndimage

    H, W = features.shape[:2]
    grad = ndimage.uniform_filter(features[..., 4], 5)
    smooth = grad < max(0.6, float(np.percentile(grad, 35)))
    labels, _ = ndimage.label(smooth)
    sky_labels, slope_labels = _top_components(features, labels)
    sky_region = np.isin(labels, sky_labels) & smooth
    slope = _eroded(np.isin(labels, slope_labels) & smooth, 3)
    sky = _eroded(sky_region, 3)
    # a sliver of sky (a slope fills most of the frame): all of it, rather than the top rows, which the slope may fill
    sliver = sky.sum() < 0.01 * H * W and sky_region.sum() >= 0.002 * H * W
    if sliver:
        sky = sky_region
    v = np.arange(H)[:, None]
    lowest_sky = np.where(sky.any(axis=0), H - 1 - np.argmax(sky[::-1], axis=0), -1)
    textured = grad > np.percentile(grad, 60)
    terrain = ((v >= int(0.8 * H)) | textured | slope) & (v > lowest_sky[None, :] + 3)
    if not sliver and sky.sum() < 0.01 * H * W:  # nothing smooth at the top: fall back to the top rows
        sky = np.broadcast_to(v < max(2, int(0.1 * H)), (H, W)).copy()
    return sky, terrain


def extract_skyline(image: np.ndarray, params: SkylineParams = SkylineParams()) -> ExtractedSkyline:
    """The sky/terrain boundary of an RGB uint8 photo (see the module docstring)."""
    H, W = image.shape[:2]
    if W > params.work_width:
        return _extract_reduced(image, params)
    if params.method not in ("select", "gmm", "net", "hybrid"):
        raise ValueError(f"unknown skyline method {params.method!r} (select, hybrid, net or gmm)")
    if params.cables is not None:
        image, _ = remove_cables(image, params.cables)
    if params.method == "gmm":
        p_net = None
        features = pixel_features(image)
    else:  # the network needs only the image: it runs beside the pixel features, on the core they leave idle
        features, p_net = concurrently(lambda: pixel_features(image),
                                       lambda: net_probability(image, params.net_weights, net_width=params.net_width))
    # each part made by whichever line asks first: with select the hybrid's line makes the colour edges (it needs them
    # at once, gmm's line only for its last boundary) and the mixtures' inputs, off gmm's longer line
    work = PhotoWork.of(features, params)
    if params.method == "select":
        if params.select_gmm_above > 0:
            # the hybrid first, on both cores; gmm only where the hybrid doubts more than a few columns
            hybrid = _extract(image, features, "hybrid", params, p_net, work)
            if not hybrid_in_doubt(hybrid, params.select_gmm_above):
                return hybrid
            gmm = _extract(image, features, "gmm", params, work=work)
            return select_skylines(hybrid, gmm, params.select_tol_px)
        # the two extractors on a thread each (1.43 -> 1.19 s a CH1 photo on 2 cores, the same skylines to the bit);
        # BLAS and OpenMP held to one thread around both, so that neither's own limits, set and restored inside,
        # can widen them under the other
        with one_thread():
            hybrid, gmm = concurrently(lambda: _extract(image, features, "hybrid", params, p_net, work),
                                       lambda: _extract(image, features, "gmm", params, work=work))
        return select_skylines(hybrid, gmm, params.select_tol_px)
    return _extract(image, features, params.method, params, p_net, work)


@dataclass(frozen=True)
class PhotoWork:
    """What every extractor of one photo computes alike from its pixel features, each part made once, on first
    request, by whichever extractor asks first (:class:`~skyrender.blocks.Once`; ``select`` runs two at once):
    the colour edges (:func:`_edge_strength`), the texture cost (:func:`_texture_cost`), and the colour
    mixtures' inputs for every pixel (:func:`~.sky.mixture_inputs`) and blue-sky bonus (:func:`~.sky.blue_sky_logit`)."""

    edges: Once
    texture: Once
    pixel_rows: Once
    blue_logit: Once

    @classmethod
    def of(cls, features: np.ndarray, params: SkylineParams) -> PhotoWork:
        """The work on ``features`` (H, W, 5), nothing made yet."""
        from .sky import blue_sky_logit, mixture_inputs

        return cls(Once(lambda: _edge_strength(features, params.edge_percentile)),
                   Once(lambda: _texture_cost(features, params.texture_weight)),
                   Once(lambda: mixture_inputs(features, dtype=np.float32)), Once(lambda: blue_sky_logit(features)))


def _extract(image: np.ndarray, features: np.ndarray, method: str, params: SkylineParams,
             p_net: np.ndarray | None = None, work: PhotoWork | None = None) -> ExtractedSkyline:
    """One extractor (``method``: gmm, net or hybrid) on a photo whose cables are painted over, its
    :func:`~.sky.pixel_features` given, and for net and hybrid the network's :func:`net_probability` ``p_net``
    (:func:`extract_skyline` runs it beside the features); ``work``: the :class:`PhotoWork` other extractors of the
    photo share, None: this one's own."""
    H = image.shape[0]
    if work is None:
        work = PhotoWork.of(features, params)
    if method == "gmm":
        p = _gmm_probability(features, work, params)
        rows = _boundary(p, _edges_where_p_changes(work.edges(), p, params.edge_contrast), params.edge_bonus,
                         params.jump_cost, params.jump_cap, work.texture())
    else:
        p = p_net
        rows = _boundary(p_net, work.edges(), *_net_boundary_weights(params))
        if method == "hybrid":
            p = _hybrid_probability(features, p_net, rows, params, work)
            rows = _boundary(p, work.edges(), params.edge_bonus, params.jump_cost, params.jump_cap, work.texture())
    sub, contrast = _subpixel(features, rows)
    skyline = boundary_skyline(rows, sub, H)
    if method == "gmm":
        return ExtractedSkyline(skyline, column_confidence(p, rows, contrast, skyline, fitted=False), p)
    # the confidence model was fitted on the network's probability: its cues come from that
    return ExtractedSkyline(skyline, column_confidence(p_net, rows, contrast, skyline, fitted=True,
                                                       net_width=params.net_width, net_weights=params.net_weights), p)


def hybrid_in_doubt(hybrid: ExtractedSkyline, share: float) -> bool:
    """Whether more than ``share`` of the hybrid's columns have a confidence below 0.5 (its fitted
    probability of lying within 5 px of the truth): only then does ``method="select"`` run gmm too."""
    return bool(np.mean(hybrid.confidence < 0.5) > share)


def select_skylines(first: ExtractedSkyline, second: ExtractedSkyline, tol_px: float = 5.0) -> ExtractedSkyline:
    """``first`` or ``second``, whole: where their skylines lie more than ``tol_px`` apart (one all
    sky and the other not counts as apart), the one whose mean column confidence over those columns
    is higher; ``first`` where they nowhere part or tie.

    Why (``method="select"``): the network-led ``hybrid`` and the per-photo ``gmm`` fail on different
    photos — the hybrid leaves a ridge for the cloud bank on it, or takes a hazy range for sky, where
    the mixtures alone hold, and the mixtures, started from the frame's top, can settle on a wrong
    boundary where the network does not — and where one fails, its own confidence on the columns in
    dispute is mostly the lower. On the 31 dev photos: the target met on 22 against 19 (hybrid) and 18
    (gmm), mean within 5 px 94.7 against 92.8 %; on the 86 training photos 60 against 57
    (``experiments/photos/select/choose.txt``). Choosing per stretch of disputed columns instead met it
    on 22 dev photos too but on 58 training photos, and mixes two extractors' lines."""
    H = first.sky_probability.shape[0]
    a, b = (np.where(np.isfinite(s.skyline), s.skyline, H + 1.0e3) for s in (first, second))
    apart = np.abs(a - b) > tol_px
    if apart.any() and second.confidence[apart].mean() > first.confidence[apart].mean():
        return second
    return first


def _net_boundary_weights(params: SkylineParams) -> tuple[float, float, float]:
    """(edge bonus, jump cost, jump cap) of the boundary search on the network's probability:
    the params' own, or as fitted on the dev photos where they are None."""
    fitted = _fitted(params.net_width, params.net_weights)
    return tuple(fitted[k] if getattr(params, k) is None else getattr(params, k)
                 for k in ("net_edge_bonus", "net_jump_cost", "net_jump_cap"))


def _hybrid_probability(features: np.ndarray, p_net: np.ndarray, rows: np.ndarray, params: SkylineParams,
                        work: PhotoWork) -> np.ndarray:
    """P(sky) of ``method="hybrid"``: the network finds the boundary (it does not lose the
    sky to a bad first guess, as per-photo mixtures can), then colour-texture mixtures are
    fitted to *this* photo's pixels on either side of it, ``params.band`` px clear, and
    their evidence is added to half the network's log-odds (the network is blurred by its
    reduced input, :data:`~skyrender.features.sky_net.NET_WIDTH` px wide; the mixtures see
    every pixel). The weight of one half was chosen on the dev photos (mean within 5 px 93.1 %
    against 92.9 % with weight 1 and 90.5 % for the network alone, at a 512-px input, where
    weight 2, or the mixtures' evidence clipped at +-3 or +-5 instead of +-10, did worse too)."""
    H = p_net.shape[0]
    v = np.arange(H)[:, None]
    sky = (v < rows[None, :] - params.band) & (p_net > 0.5)
    terrain = (v >= rows[None, :] + params.band) & (p_net < 0.5)
    tol, samples = params.mixture_budget()
    p_colour = sky_probability(features, sky, terrain, _row_prior(H), components=params.components,
                               max_samples=samples, tol=tol, seed=0, pixel_rows=work.pixel_rows,
                               blue_logit=work.blue_logit)
    logit = _logit(p_net)
    logit *= HYBRID_NET_WEIGHT
    logit += _logit(p_colour)
    np.negative(logit, out=logit)  # the logistic function, in place: 1 / (1 + exp(-logit))
    np.exp(logit, out=logit)
    logit += 1.0
    return np.divide(1.0, logit, out=logit).astype(np.float32, copy=False)


HYBRID_NET_WEIGHT = 0.5


def _logit(p: np.ndarray) -> np.ndarray:
    """log(p / (1 - p)) of ``p`` clipped to [1e-4, 1 - 1e-4], in ``p``'s dtype (a new array)."""
    p = np.clip(p, 1e-4, 1 - 1e-4)
    odds = np.subtract(1, p)
    np.divide(p, odds, out=odds)
    return np.log(odds, out=odds)


def net_probability(image: np.ndarray, weights: str | None = None, net_width: int = NET_WIDTH) -> np.ndarray:
    """(H, W) float32 P(sky) of the sky network (another ONNX file: ``weights``) on a copy
    ``net_width`` px wide, scaled up to the photo's size."""
    import cv2

    H, W = image.shape[:2]
    logits = sky_logits(image, net_width) if weights is None else sky_logits(image, net_width, weights=weights)
    logits = cv2.resize(logits, (W, H), interpolation=cv2.INTER_LINEAR)
    return (1.0 / (1.0 + np.exp(-np.clip(logits, -30, 30)))).astype(np.float32)


def skyline_of_terrain(terrain: np.ndarray) -> np.ndarray:
    """Skyline (W,) of a terrain mask (H, W), True (or non-zero) = terrain: per column the v of the top edge of its
    first terrain pixel (px; the topmost change where a column changes more than once), NaN where the column is all
    sky, 0 where terrain reaches the top edge (CONTRACT.md, *Skyline*)."""
    terrain = np.asarray(terrain, bool)
    v = np.argmax(terrain, axis=0).astype(np.float64)
    v[~terrain.any(axis=0)] = np.nan
    return v


def sky_mask_of_skyline(skyline: np.ndarray, height: int) -> np.ndarray:
    """(height, W) bool sky mask of a skyline (W,) (px; NaN: all sky): a pixel is sky where its centre lies above the
    line (row + 0.5 < v). :func:`skyline_of_terrain` of its complement gives the skyline back rounded to whole rows,
    exactly where it was whole (a mask's own skyline)."""
    v = np.nan_to_num(np.asarray(skyline, np.float64), nan=float(height))
    return (np.arange(height) + 0.5)[:, None] < v[None, :]


def boundary_skyline(rows: np.ndarray, sub: np.ndarray, H: int) -> np.ndarray:
    """Skyline (W,) from integer boundary rows and their sub-pixel refinement: NaN where a
    column is all sky (row H), 0 where terrain reaches the top edge."""
    return np.where(rows >= H, np.nan, np.where(rows <= 0, 0.0, sub))


def _gmm_probability(features: np.ndarray, work: PhotoWork, params: SkylineParams) -> np.ndarray:
    """P(sky) from colour-texture mixtures re-fitted to this photo (``method="gmm"``; ``work``: its
    :class:`PhotoWork`).

    With ``params.draft_scale`` > 1 the rounds before the last, which only place the next
    round's training pixels, run on every ``draft_scale``-th row and column and fit on
    ``draft_samples`` pixels (photos ``draft_min_width`` px wide or wider); the last round
    sees every pixel."""
    H, W = features.shape[:2]
    v = np.arange(H)[:, None]
    sky_mask, terrain_mask = initial_seeds(features)
    s = max(1, int(params.draft_scale)) if W >= params.draft_min_width else 1
    draft = np.ascontiguousarray(features[::s, ::s])  # once, rather than a copy in each use of a strided view
    texture = work.texture()
    tol, samples = params.mixture_budget()
    draft_edges = None  # the draft's colour edges: the same in every round
    full = {} if s > 1 else {"pixel_rows": work.pixel_rows, "blue_logit": work.blue_logit}  # no draft: the photo's own
    for round_ in range(params.rounds - 1):
        p = sky_probability(draft, sky_mask[::s, ::s], terrain_mask[::s, ::s], _row_prior(draft.shape[0]),
                            components=params.components, seed=round_, tol=tol,
                            max_samples=params.draft_samples if s > 1 else samples, **full)
        if draft_edges is None:
            draft_edges = _edge_strength(draft, params.edge_percentile) if s > 1 else work.edges()
        rows = _boundary(p, _edges_where_p_changes(draft_edges, p, params.edge_contrast), params.edge_bonus,
                         params.jump_cost / s,
                         params.jump_cap, None if texture is None else texture[::s, ::s])
        rows = np.repeat(rows, s)[:W] * s  # back to full-resolution rows and columns
        sky_mask = v < rows[None, :] - params.band
        terrain_mask = v >= rows[None, :] + params.band
    return sky_probability(features, sky_mask, terrain_mask, _row_prior(H), components=params.components,
                           max_samples=samples, tol=tol, seed=params.rounds - 1, pixel_rows=work.pixel_rows,
                           blue_logit=work.blue_logit)


def _texture_cost(features: np.ndarray, weight: float) -> np.ndarray | None:
    """(H, W) extra cost of labelling textured pixels sky (gradient over its 90th
    percentile, capped at 1, times ``weight``); None for no weight."""
    if not weight:
        return None
    grad = features[..., 4]
    return weight * np.clip(grad / max(float(np.percentile(grad, 90)), 1e-3), 0, 1)


def _edges_where_p_changes(edges: np.ndarray, p: np.ndarray, gain: float, reach: int = 2) -> np.ndarray:
    """(H+1, W) ``edges`` (:func:`_edge_strength`, between rows b-1 and b) times how much P(sky) ``p`` (H, W)
    changes across each: |mean of the ``reach`` rows above - mean of the ``reach`` below| times ``gain``, at most
    1; ``edges`` as they are for no gain. A colour edge between two stretches of terrain (or of sky) then earns
    the boundary nothing."""
    if not gain:
        return edges
    H, W = p.shape
    csum = row_prefix_sums(p, np.float64)
    b = np.arange(H + 1)[:, None]
    cols = np.arange(W)[None, :]
    top, bottom = np.clip(b - reach, 0, H), np.clip(b + reach, 0, H)
    above = (csum[b, cols] - csum[top, cols]) / np.maximum(b - top, 1)
    below = (csum[bottom, cols] - csum[b, cols]) / np.maximum(bottom - b, 1)
    return edges * np.clip(gain * np.abs(above - below), 0.0, 1.0)


def row_prefix_sums(a: np.ndarray, dtype=None) -> np.ndarray:
    """(H+1, ...) float64 sums of the rows of ``a`` (H, ...) above each row index: row k the sum of rows 0..k-1 (row 0
    zeros), accumulated row after row in ``dtype`` (None: ``a``'s), as ``np.cumsum(a, axis=0, dtype=dtype)`` with a
    zero row on top, to the bit. One vector add a row: numpy's accumulation down the first axis of a C-order array
    goes element by element, 10x slower on a photo."""
    out = np.zeros((len(a) + 1,) + a.shape[1:])
    acc = out[1:] if np.dtype(dtype or a.dtype) == out.dtype else np.empty(a.shape, dtype or a.dtype)
    if len(a):
        acc[0] = a[0]
        for k in range(1, len(a)):
            np.add(acc[k - 1], a[k], out=acc[k])
    if acc.base is not out:
        out[1:] = acc
    return out


def _boundary(p: np.ndarray, edges: np.ndarray, edge_bonus: float, jump_cost: float, jump_cap: float,
              texture: np.ndarray | None = None) -> np.ndarray:
    """(W,) integer boundary row per column (H: all sky) minimising misclassified
    probability mass (plus ``texture`` cost on the sky side) minus the colour-edge bonus
    (``edges`` from :func:`_edge_strength`), with the jump penalty (:func:`boundary_dp`)."""
    sky_cost = 1.0 - p if texture is None else (1.0 - p) + texture  # what labelling a pixel sky costs
    unary = row_prefix_sums(sky_cost - p)
    return boundary_dp(unary - edge_bonus * edges, jump_cost, jump_cap)


def confidence_features(p: np.ndarray, rows: np.ndarray, contrast: np.ndarray, skyline: np.ndarray) -> np.ndarray:
    """(W, 4) per-column cues of a trustworthy boundary: the probability margin (mean P(sky)
    in 6 rows above minus 6 rows below), the colour contrast across it (Lab units / 15,
    capped at 2), the boundary's roughness (|second difference| of v, px, capped at 20)
    and the probability's own uncertainty at the boundary row (1 - |2p - 1|)."""
    H, W = p.shape
    cols = np.arange(W)
    csum = row_prefix_sums(p)  # csum[k] = sum of p over rows < k

    def band_mean(start, stop, default):
        start, stop = np.clip(start, 0, H), np.clip(stop, 0, H)
        total = csum[stop, cols] - csum[start, cols]
        return np.where(stop > start, total / np.maximum(stop - start, 1), default)

    margin = band_mean(rows - 6, rows - 1, 1.0) - band_mean(rows + 1, rows + 6, 0.0)
    v = np.where(np.isfinite(skyline), skyline, H)
    rough = np.abs(np.convolve(np.pad(v, 1, mode="edge"), [1.0, -2.0, 1.0], mode="valid"))
    at = p[np.clip(rows, 0, H - 1), cols]
    return np.column_stack([margin, np.minimum(contrast / 15.0, 2.0), np.minimum(rough, 20.0),
                            1.0 - np.abs(2.0 * at - 1.0)])


DEFAULT_FIT = {"net_edge_bonus": 4.0, "net_jump_cost": 0.25, "net_jump_cap": 12.0, "coef": None, "intercept": None}


@lru_cache(maxsize=4)
def _fitted(net_width: int = NET_WIDTH, net_weights: str | None = None) -> dict:
    """The weights fitted on the dev photos for the network (``net_weights``, None: the
    shipped one) at ``net_width`` (those of the default width where that width has none),
    or neutral ones before any fit."""
    path = fitted_path(net_width, net_weights)
    path = path if os.path.exists(path) else fitted_path(NET_WIDTH, net_weights)
    if not os.path.exists(path):
        return DEFAULT_FIT
    with open(path) as f:
        return {**DEFAULT_FIT, **json.load(f)}


def column_confidence(p: np.ndarray, rows: np.ndarray, contrast: np.ndarray, skyline: np.ndarray,
                      fitted: bool = True, net_width: int = NET_WIDTH, net_weights: str | None = None) -> np.ndarray:
    """(W,) in [0, 1]. ``fitted`` (the network's probability, run ``net_width`` px wide): the
    probability, fitted on the dev photos, that the column is within 5 px of the truth;
    otherwise (the per-photo mixtures, or no fitted model shipped) the probability margin
    times the contrast / 15."""
    x = confidence_features(p, rows, contrast, skyline)
    model = _fitted(net_width, net_weights)
    if not fitted or model["coef"] is None:
        return np.clip(x[:, 0], 0, 1) * np.clip(x[:, 1], 0, 1)
    return 1.0 / (1.0 + np.exp(-(x @ np.asarray(model["coef"]) + model["intercept"])))


def _extract_reduced(image: np.ndarray, params: SkylineParams) -> ExtractedSkyline:
    """Extract on a copy reduced to ``params.reduced_width`` (at most ``work_width``), then refine each column at full
    resolution: the strongest colour edge within (scale + 2) px of the scaled-up boundary,
    then the sub-pixel step. Coordinates are those of the full image."""
    import cv2

    H, W = image.shape[:2]
    width = min(params.reduced_width, params.work_width)
    scale = W / width
    small = cv2.resize(image, (width, int(round(H / scale))), interpolation=cv2.INTER_AREA)
    coarse = extract_skyline(small, params)
    sx = W / small.shape[1]
    sy = H / small.shape[0]
    u_small = (np.arange(W) + 0.5) / sx - 0.5
    base = np.arange(small.shape[1])

    def upcol(values):
        return np.interp(u_small, base, values)

    finite = np.isfinite(coarse.skyline)
    v0 = upcol(np.where(finite, coarse.skyline, small.shape[0])) * sy
    all_sky = upcol((~finite).astype(float)) > 0.5
    reach = int(np.ceil(max(sx, sy))) + 2
    rows = _refine_in_band(image, np.round(v0).astype(int), reach)
    band = image[np.clip(rows[None, :] + np.arange(-6, 6)[:, None], 0, H - 1), np.arange(W)[None, :]]
    lab = cv2.cvtColor(band.astype(np.float32) / 255.0, cv2.COLOR_RGB2Lab)
    local = np.concatenate([lab, np.zeros(lab.shape[:2] + (2,), np.float32)], axis=2)
    sub, _ = _subpixel(local, np.full(W, 6))
    skyline = np.where(all_sky, np.nan, np.where(rows <= 0, 0.0, sub - 6 + rows))
    p_full = cv2.resize(coarse.sky_probability, (W, H), interpolation=cv2.INTER_LINEAR)
    confidence = np.interp(u_small, base, coarse.confidence)
    return ExtractedSkyline(skyline, confidence, p_full)


def _refine_in_band(image: np.ndarray, rows: np.ndarray, reach: int) -> np.ndarray:
    """(W,) per column, the boundary row within ``reach`` of ``rows`` with the largest Lab
    contrast between the 3 rows above and the 3 below, ties to the nearest."""
    import cv2

    H, W = image.shape[:2]
    offsets = np.arange(-reach - 3, reach + 3)
    band_rows = np.clip(rows[None, :] + offsets[:, None], 0, H - 1)
    band = image[band_rows, np.arange(W)[None, :]]
    lab = cv2.cvtColor(band.astype(np.float32) / 255.0, cv2.COLOR_RGB2Lab).astype(np.float64)
    csum = np.concatenate([np.zeros((1, W, 3)), np.cumsum(lab, axis=0)])
    b = np.arange(3, 2 * reach + 4)  # boundary between band rows b-1 and b
    contrast = np.linalg.norm((csum[b] - csum[b - 3]) - (csum[b + 3] - csum[b]), axis=2) / 3.0
    contrast -= 0.05 * np.abs(offsets[b])[:, None]  # ties to the nearest
    best = offsets[b][np.argmax(contrast, axis=0)]
    return np.clip(rows + best, 0, H)
