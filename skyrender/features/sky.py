"""Per-pixel sky probability for a photograph.

Pixel features: CIE Lab colour, local texture (standard deviation of
lightness in a 7 x 7 window, and gradient magnitude) and image row (sky
colour changes with elevation angle). The
probability combines a prior on the row with colour-texture models learned
*from the photo itself*: Gaussian mixtures (scikit-learn's fit from its k-means start,
each EM step vectorised over the components: :func:`_fit_gmm`) fitted to pixels
labelled sky and terrain by the previous boundary estimate (the first round
seeds them from the top and bottom of the frame). Self-training adapts to
what a fixed classifier cannot know: this photo's sky, haze and snow.

Three physical cues are added to the mixtures' evidence: smooth blue pixels
are likely sky (blue gaps between clouds), unless they are clearly darker
than the smooth clear-sky colour field at their position (snow faces in
shadow are blue too, but darker than the sky beside them); and a pixel as
light as a blue clear-sky field but clearly greyer is not sky (a distant
ridge through haze; clouds are greyer too, but brighter).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


def pixel_features(image: np.ndarray) -> np.ndarray:
    """(H, W, 5) float32 features of an RGB uint8 image: L, a, b (CIE Lab, L in 0..100),
    local lightness std (7 x 7) and Sobel gradient magnitude of lightness."""
    import cv2

    rgb = cv2.GaussianBlur(image, (3, 3), 0).astype(np.float32)
    rgb /= 255.0
    lab = cv2.cvtColor(rgb, cv2.COLOR_RGB2Lab)
    out = np.empty(lab.shape[:2] + (5,), np.float32)  # each feature written into its channel, no stacking copies
    out[..., :3] = lab
    L = lab[..., 0]
    mean = cv2.blur(L, (7, 7))
    variance = cv2.blur(L * L, (7, 7))
    variance -= mean * mean
    np.sqrt(np.maximum(variance, 0, out=variance), out=out[..., 3])
    gx = cv2.Sobel(L, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(L, cv2.CV_32F, 0, 1, ksize=3)
    gx *= gx
    gy *= gy
    gx += gy
    np.sqrt(gx, out=gx)
    np.divide(gx, 8.0, out=out[..., 4])
    return out


@dataclass(frozen=True)
class Mixture:
    """A full-covariance Gaussian mixture of K components in D dimensions: ``weights`` (K,),
    ``means`` (K, D) and ``precisions_cholesky`` (K, D, D), upper-triangular P_k with
    precision_k = P_k P_k^T (scikit-learn's ``precisions_cholesky_``); the EM steps it took
    and whether it converged."""

    weights: np.ndarray
    means: np.ndarray
    precisions_cholesky: np.ndarray
    iterations: int
    converged: bool


#: The colour mixtures' EM: covariance regularisation (added to the diagonal), step limit and
#: tolerance on the mean log-likelihood's change (scikit-learn's reg_covar, max_iter and tol).
GMM_REG_COVAR = 0.5
GMM_MAX_ITER = 50  # plenty for a probability map
GMM_TOL = 1e-3
#: pixels a class the full-resolution fits sample (the EM's other budget)
MIXTURE_SAMPLES = 12_000


def _fit_gmm(samples: np.ndarray, components: int, seed: int, tol: float = GMM_TOL) -> Mixture:
    """Full-covariance Gaussian mixture of ``samples`` (N, D), deterministic for a seed: what
    scikit-learn's ``GaussianMixture(covariance_type="full", reg_covar=GMM_REG_COVAR,
    max_iter=GMM_MAX_ITER, tol=tol, random_state=seed)`` fits (its k-means start, then the same EM
    steps and stop, to ~1e-10), with each EM step over all components in a few matrix
    products instead of several passes per component. The k-means start is scikit-learn's too
    (:mod:`.kmeans`), without importing it.
    """
    from ..blocks import one_thread
    from .kmeans import kmeans_labels

    x = np.asarray(samples, np.float64)
    n = int(min(components, max(1, len(x) // 50)))
    # one thread: the fit's matrices are a few thousand by 6, and BLAS / OpenMP threads on them
    # cost more than they share (a fit 3x faster on 2 cores; the same fit to the bit)
    with one_thread():
        labels = kmeans_labels(x, n, seed)
        centre = x.mean(axis=0)
        x = x - centre  # fitted centred (covariances from outer products), the means moved back at the end
        outer = (x[:, :, None] * x[:, None, :]).reshape(len(x), -1)
        resp = np.zeros((n, len(x)))
        resp[labels, np.arange(len(x))] = 1.0
        nk, means, chol = _mixture_m_step(x, outer, resp, GMM_REG_COVAR)
        mixture = Mixture(nk / len(x), means, chol, 0, False)
        lower = -np.inf
        for step in range(1, GMM_MAX_ITER + 1):
            log_prob = _weighted_log_prob(x, mixture)
            norm = _logsumexp_columns(log_prob)
            log_prob -= norm  # log responsibilities
            nk, means, chol = _mixture_m_step(x, outer, np.exp(log_prob, out=log_prob), GMM_REG_COVAR)
            previous, lower = lower, float(np.mean(norm))
            mixture = Mixture(nk / nk.sum(), means, chol, step, abs(lower - previous) < tol)
            if mixture.converged:
                break
    return replace(mixture, means=mixture.means + centre)


def _mixture_m_step(x: np.ndarray, outer: np.ndarray, resp: np.ndarray,
                    reg_covar: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One M step: the components' soft counts (K,), means (K, D) and precision Cholesky
    factors (K, D, D) from samples ``x`` (N, D), their outer products ``outer`` (N, D*D) and
    responsibilities ``resp`` (K, N). Every component's weighted scatter is one matrix product
    (``resp @ outer``) less its mean's outer product: with ``x`` centred on its mean that
    difference loses ~1e-12 of the covariance."""
    from scipy.linalg import solve_triangular

    K, D = resp.shape[0], x.shape[1]
    nk = resp.sum(axis=1) + 10 * np.finfo(resp.dtype).eps
    means = (resp @ x) / nk[:, None]
    covariances = (resp @ outer).reshape(K, D, D) / nk[:, None, None] - means[:, :, None] * means[:, None, :]
    covariances[:, np.arange(D), np.arange(D)] += reg_covar
    try:
        lower = np.linalg.cholesky(covariances)
    except np.linalg.LinAlgError as e:  # not with reg_covar: a collapsed component still has it
        raise ValueError("a colour mixture's covariance is not positive definite") from e
    eye = np.eye(D)
    return nk, means, np.stack([solve_triangular(c, eye, lower=True).T for c in lower])


def _log_density_terms(m: Mixture) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(stacked (K*D, D), shift (K*D, 1), block_sum (K, K*D), const (K, 1)) such that the K
    components' weighted log densities at columns x (D, N) are
    -0.5 block_sum @ (stacked @ x - shift)^2 + const."""
    K, D = m.means.shape
    chol = m.precisions_cholesky
    stacked = chol.transpose(0, 2, 1).reshape(K * D, D)  # stacked @ x = [chol_k^T x for each k]
    shift = np.einsum("kd,kde->ke", m.means, chol).reshape(K * D, 1)
    block_sum = np.kron(np.eye(K), np.ones((1, D)))  # (K, K * D): sums each component's D squares
    # per component: log |prec_chol_k| + log w_k - D/2 log(2 pi)
    const = np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(axis=1) + np.log(m.weights) - 0.5 * D * np.log(2 * np.pi)
    return stacked, shift, block_sum, const[:, None]


def _weighted_log_prob(x: np.ndarray, m: Mixture, terms: tuple | None = None) -> np.ndarray:
    """(K, N) log (w_k N(x | component k)) at the rows of ``x`` (N, D), every component in
    two matrix products (``terms``: :func:`_log_density_terms` of ``m``, when already made).
    Components run along the first axis, so the sums over them are whole-row passes."""
    stacked, shift, block_sum, const = _log_density_terms(m) if terms is None else terms
    y = stacked @ x.T
    y -= shift
    np.square(y, out=y)
    log_prob = block_sum @ y
    log_prob *= -0.5
    log_prob += const
    return log_prob


def _logsumexp_columns(a: np.ndarray) -> np.ndarray:
    """(N,) log sum exp over the columns of ``a`` (K, N), shifted by each column's maximum."""
    top = a.max(axis=0)
    return top + np.log(np.exp(a - top).sum(axis=0))


def mixture_log_density(m: Mixture, x: np.ndarray, chunk: int = 65_536) -> np.ndarray:
    """(N,) log density of a fitted mixture (:func:`_fit_gmm`) at the rows of ``x`` (N, D), computed in
    ``x``'s dtype, with every component in two matrix products per chunk of rows instead of a pass per
    component (3.5x faster on a photo). float64 rows give scikit-learn's ``score_samples`` for the same
    mixture (to 1e-12); float32 rows, what :func:`sky_probability` passes for a photo's every pixel, give
    it to ~1e-4 in about 0.6 of the time (half the bytes through memory, numpy's float32 ``exp``), and
    the same skylines (``experiments/photos/float32-densities/``). The chunks run on all cores
    (:func:`~skyrender.blocks.in_blocks`), each row's value computed as in one chunk at a time, to the bit."""
    from ..blocks import in_blocks, one_thread

    dtype = np.float32 if x.dtype == np.float32 else np.float64
    terms = tuple(t.astype(dtype, copy=False) for t in _log_density_terms(m))
    out = np.empty(len(x), dtype)

    def rows(start: int, stop: int) -> None:
        out[start:stop] = _logsumexp_columns(_weighted_log_prob(x[start:stop], m, terms))

    with one_thread("blas"):  # the chunks are the threads; BLAS threads inside them would fight
        in_blocks(len(x), chunk, rows)
    return out


def blue_sky_logit(features: np.ndarray, weight: float = 12.0) -> np.ndarray:
    """(H, W) log-odds bonus for smooth blue pixels: clear sky is blue everywhere, so a
    blue patch between clouds is sky even when this photo's sky model learned only clouds.
    Blue (Lab b* below -8) must also be smooth (texture below 3): snow shadows are blue too."""
    blue = np.clip((-features[..., 2] - 8.0) / 15.0, 0, 1)
    smooth = np.clip(1.0 - features[..., 3] / 3.0, 0, 1)
    return weight * blue * smooth


def _quadratic_design(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(..., 6) terms 1, u, v, u^2, uv, v^2 of coordinates already scaled to about [-0.5, 0.5]
    (u and v broadcast against each other: a column and a row give the whole grid)."""
    u, v = np.broadcast_arrays(u, v)
    return np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1)


def clear_sky_field(features: np.ndarray, sky_mask: np.ndarray, *, max_samples: int = 20_000,
                    seed: int = 0) -> tuple[np.ndarray, float] | None:
    """Smooth Lab colour field of the sky, fitted to the ``sky_mask`` pixels.

    A quadratic in the pixel coordinates per Lab channel, fitted by least squares
    with outliers (clouds, mislabelled terrain: beyond 3 robust sigma) dropped
    twice. Returns ((H, W, 3) field, robust residual sigma in Lab units), or None
    with fewer than 50 sky pixels. A clear sky is such a field to about 1 Lab unit.
    """
    H, W = features.shape[:2]
    idx = np.flatnonzero(sky_mask.ravel())
    if len(idx) < 50:
        return None
    if len(idx) > max_samples:
        idx = np.random.default_rng(seed).choice(idx, max_samples, replace=False)
    v, u = np.divmod(idx, W)
    design = _quadratic_design((u + 0.5) / W - 0.5, (v + 0.5) / H - 0.5)
    lab = features.reshape(H * W, -1)[idx, :3].astype(np.float64)  # no copy of every pixel's Lab first
    keep = np.ones(len(idx), dtype=bool)
    for _ in range(3):
        coef = np.linalg.lstsq(design[keep], lab[keep], rcond=None)[0]
        residual = np.linalg.norm(lab - design @ coef, axis=1)
        sigma = 1.4826 * float(np.median(residual[keep]))
        keep = residual <= max(3.0 * sigma, 2.0)
    return _quadratic_field(coef, H, W), sigma


def _quadratic_field(coef: np.ndarray, H: int, W: int) -> np.ndarray:
    """(H, W, C) float32 values of the quadratics ``coef`` (6, C) (terms as :func:`_quadratic_design`)
    at every pixel centre: per row, a polynomial in u whose coefficients depend on v, so the grid
    costs a few (H, W) passes instead of an (H, W, 6) design matrix (0.035-0.08 s -> 0.013-0.02 s at 1024 x 768,
    the same float32 values)."""
    u = (np.arange(W) + 0.5) / W - 0.5
    v = (np.arange(H) + 0.5) / H - 0.5
    field = np.empty((H, W, coef.shape[1]), np.float32)
    value = np.empty((H, W))  # one float64 buffer for every channel, the operations in place
    for c in range(coef.shape[1]):
        k0, ku, kv, kuu, kuv, kvv = coef[:, c]
        constant = (k0 + kv * v + kvv * v * v)[:, None]  # (H, 1)
        linear = (ku + kuv * v)[:, None]  # (H, 1)
        np.add(linear, kuu * u, out=value)
        value *= u
        value += constant
        field[..., c] = value  # constant + u * (linear + kuu * u)
    return field


def blue_field_weight(field: np.ndarray) -> np.ndarray:
    """(H, W) in [0, 1]: how blue the clear-sky field is (0 above b* -10, 1 below -20).
    The clear-sky cues below count only where the sky itself is blue."""
    return np.clip((-field[..., 2] - 10.0) / 10.0, 0, 1)


def shadowed_snow_logit(features: np.ndarray, field: np.ndarray, sigma: float, weight: float = 20.0,
                        blue_weight: np.ndarray | None = None) -> np.ndarray:
    """(H, W) log-odds penalty for pixels darker than the clear-sky field at their position.

    Counts where the field itself is blue (b* below -10, fully below -20): in a clear
    blue sky nothing is more than max(4, 3 sigma) Lab L units darker than the sky around
    it, but a snow face in shadow is, while it is as blue and smooth as sky. Under a
    cloudy sky the field is grey and the blue gaps are darker than it: no penalty there.
    ``blue_weight``: :func:`blue_field_weight` of the field, where already made.
    """
    darker = field[..., 0] - features[..., 0]
    darker -= max(4.0, 3.0 * sigma)  # in place from here, the operations in the order of the formula
    darker /= 6.0
    penalty = (blue_field_weight(field) if blue_weight is None else blue_weight) * weight
    penalty *= np.clip(darker, 0, 1, out=darker)
    return penalty  # weight * blue_field_weight(field) * clip((darker - threshold) / 6, 0, 1)


def hazy_ridge_logit(features: np.ndarray, field: np.ndarray, sigma: float, weight: float = 20.0,
                     blue_weight: np.ndarray | None = None) -> np.ndarray:
    """(H, W) log-odds penalty for pixels greyer than a blue clear-sky field, yet no brighter.

    A distant snow ridge seen through haze has the sky's lightness but is markedly
    less blue (weisshorn: sky L 62, b* -35; the ridge L 60, b* -22). Pixels more than
    max(8, 3 sigma) b* units less blue than the field are penalised, unless they are
    over 4 L units brighter than it: clouds are that, and clouds are sky. Counts only
    where the field itself is blue, as :func:`shadowed_snow_logit` does (``blue_weight``: as there).
    """
    greyer = features[..., 2] - field[..., 2]
    greyer -= max(8.0, 3.0 * sigma)  # in place from here, the operations in the order of the formula
    greyer /= 6.0
    no_brighter = features[..., 0] - field[..., 0]  # how much brighter, then how far from 4 L units brighter
    np.subtract(4.0, no_brighter, out=no_brighter)
    no_brighter /= 4.0
    penalty = (blue_field_weight(field) if blue_weight is None else blue_weight) * weight
    penalty *= np.clip(greyer, 0, 1, out=greyer)
    penalty *= np.clip(no_brighter, 0, 1, out=no_brighter)
    return penalty  # weight * blue_field_weight(field) * clip((greyer - threshold) / 6, 0, 1) * no_brighter


#: The image row's weight among the mixtures' features (the row, 0-1 down the frame, times this).
ROW_WEIGHT = 20.0


def mixture_inputs(features: np.ndarray, row_weight: float = ROW_WEIGHT, *, pixels: np.ndarray | None = None,
                   dtype=np.float64) -> np.ndarray:
    """(N, C [+ 1]) rows the colour mixtures see, in ``dtype``: the features (H, W, C) of the pixels at flat
    indices ``pixels`` (None: every pixel, N = H * W) and, with a ``row_weight``, each one's image row scaled to
    [0, row_weight] (sky colour changes with elevation angle; computed in float64 before any cast)."""
    H, W, C = features.shape
    flat = features.reshape(-1, C)
    n = H * W if pixels is None else len(pixels)
    x = np.empty((n, C + 1 if row_weight else C), dtype)
    x[:, :C] = flat if pixels is None else flat[pixels]
    if row_weight:
        row_value = (np.arange(H) + 0.5) / H * row_weight  # (H,) float64, then one value per pixel
        x[:, C] = np.repeat(row_value, W) if pixels is None else row_value[pixels // W]
    return x


def sky_probability(features: np.ndarray, sky_mask: np.ndarray, terrain_mask: np.ndarray,
                    row_prior: np.ndarray, *, components: int = 5, max_samples: int = MIXTURE_SAMPLES,
                    tol: float = GMM_TOL, row_weight: float = ROW_WEIGHT, seed: int = 0,
                    pixel_rows=None, blue_logit=None) -> np.ndarray:
    """(H, W) P(sky) from colour-texture mixtures fitted to the given sky / terrain pixels.

    ``row_prior`` (H,) is the prior P(sky) per row; the mixtures are fitted on at most ``max_samples``
    pixels a class, their EM stopped at ``tol`` (:func:`_fit_gmm`). Deterministic for a seed.
    ``pixel_rows`` (``mixture_inputs(features, row_weight, dtype=np.float32)``) and ``blue_logit``
    (``blue_sky_logit(features)``), or :class:`~skyrender.blocks.Once` makers of them, where another
    call on the same features shares them; None: made here.
    """
    from ..blocks import concurrently, made, one_thread

    H, W = features.shape[:2]
    rng = np.random.default_rng(seed)

    def pick(mask):  # float64 samples: the fits as they were before the densities went float32, to the bit
        idx = np.flatnonzero(mask.ravel())
        if len(idx) > max_samples:
            idx = rng.choice(idx, max_samples, replace=False)
        return mixture_inputs(features, row_weight, pixels=idx)

    s, t = pick(sky_mask), pick(terrain_mask)
    if len(s) < 20 or len(t) < 20:  # one class absent: the prior alone decides
        return np.broadcast_to(row_prior[:, None], (H, W)).astype(np.float32)
    # the two fits are independent: one thread each (a 1024-wide CH1 photo's pair 0.36 s -> 0.24 s, the same fits
    # to the bit); BLAS held to one thread for both from here, so neither fit's exit lets it widen again
    with one_thread("blas"):
        gmm_sky, gmm_terrain = concurrently(lambda: _fit_gmm(s, components, seed, tol),
                                            lambda: _fit_gmm(t, components, seed + 1, tol))
    x = mixture_inputs(features, row_weight, dtype=np.float32) if pixel_rows is None else made(pixel_rows)
    evidence = mixture_log_density(gmm_sky, x)
    evidence -= mixture_log_density(gmm_terrain, x)
    prior = np.clip(row_prior, 1e-3, 1 - 1e-3)
    # the mixtures' evidence saturates at +-10 so that the row and blue-sky priors still count; the arrays are
    # (H, W) and worked in place, the row prior's log-odds one value a row
    logit = np.clip(evidence, -10, 10, out=evidence).reshape(H, W) + np.log(prior / (1 - prior))[:, None]
    logit += blue_sky_logit(features) if blue_logit is None else made(blue_logit)
    sky_field = clear_sky_field(features, sky_mask, seed=seed)
    if sky_field is not None:
        blue = blue_field_weight(sky_field[0])
        penalty = shadowed_snow_logit(features, *sky_field, blue_weight=blue)
        penalty += hazy_ridge_logit(features, *sky_field, blue_weight=blue)
        logit -= penalty
    np.negative(logit, out=logit)  # the logistic function, in place: 1 / (1 + exp(-logit))
    np.exp(logit, out=logit)
    logit += 1.0
    return np.divide(1.0, logit, out=logit).astype(np.float32)
