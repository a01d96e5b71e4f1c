"""The sky network's training augmentations (numpy and OpenCV only: no PyTorch needed) and its layouts (PyTorch)."""

import numpy as np

from skyrender.training.sky_net import augment, depth_below_skyline, recolour_regions, swap_sky


def _scene(H=60, W=80):
    """A blue sky over dark terrain whose top edge rises from row 40 (left) to row 20 (right)."""
    top = np.linspace(40, 20, W).round().astype(int)
    v = np.arange(H)[:, None]
    sky = (v < top[None, :]).astype(np.float32)
    img = np.where(sky[..., None] > 0.5, np.array([0.3, 0.5, 0.9]), np.array([0.2, 0.25, 0.15]))
    return img + 0.02 * np.random.default_rng(0).random((H, W, 3)), sky, top


def test_depth_below_skyline_counts_rows_from_the_top_terrain_pixel():
    _, sky, top = _scene()
    sky[:, 5] = np.nan  # unknown truth in one column
    depth = depth_below_skyline(sky)
    assert depth[top[0], 0] == 0 and depth[top[0] + 7, 0] == 7 and depth[top[0] - 3, 0] == -3
    assert np.all(np.isinf(depth[:, 5]))


def test_recolouring_changes_one_side_only_and_fades_with_depth():
    img, sky, top = _scene()
    terrain = sky < 0.5
    kinds = set()
    for seed in range(40):
        out = recolour_regions(img, sky, np.random.default_rng(seed))
        changed = np.abs(out - img).max(axis=2) > 1e-9
        sky_changed, terrain_changed = changed[~terrain].any(), changed[terrain].any()
        assert not (sky_changed and terrain_changed)
        assert out.min() >= 0.0 and out.max() <= 1.2  # a sky tint brightens by 20 % at most (augment clips later)
        if terrain_changed:
            kinds.add("terrain")
            shift = np.abs(out - img).max(axis=2)
            # the terrain just under the skyline moves more than the terrain 15 rows further down
            u = np.arange(img.shape[1])
            assert np.mean(shift[top, u]) > np.mean(shift[top + 15, u])
        elif sky_changed:
            kinds.add("sky")
    assert kinds == {"terrain", "sky"}


def test_augment_is_deterministic_for_a_seed_and_keeps_the_labels_of_no_recolouring():
    img, sky, _ = _scene(120, 160)
    image = (np.clip(img, 0, 1) * 255).astype(np.uint8)
    a = augment(image, sky, np.random.default_rng(3), recolour=1.0)
    b = augment(image, sky, np.random.default_rng(3), recolour=1.0)
    c = augment(image, sky, np.random.default_rng(3), recolour=0.0)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert np.array_equal(a[1], c[1]) and np.array_equal(a[2], c[2])  # recolouring never moves the boundary
    assert not np.array_equal(a[0], c[0])


def test_a_swapped_sky_replaces_the_sky_only_and_keeps_the_boundary():
    img, sky, top = _scene(120, 160)
    image = (np.clip(img, 0, 1) * 255).astype(np.uint8)
    donor = np.zeros((90, 120, 3), np.uint8)
    donor[:, :] = (250, 120, 10)  # an orange sky over terrain below row 60 (a third of its rows are terrain)
    donor_sky = np.ones((90, 120), np.float32)
    donor_sky[60:] = 0.0
    donor_sky[:, 7] = np.nan  # a column of unknown truth does not shorten the clear band
    out = swap_sky(image, sky, donor, donor_sky)
    terrain = sky < 0.5
    assert np.array_equal(out[terrain], image[terrain])  # the terrain untouched
    assert np.abs(out[~terrain].astype(int) - (250, 120, 10)).max() <= 1  # the sky the donor's
    sky_unknown = sky.copy()
    sky_unknown[:, 3] = np.nan
    assert np.array_equal(swap_sky(image, sky_unknown, donor, donor_sky)[:, 3], image[:, 3])  # unknown truth kept
    thin = donor_sky.copy()
    thin[10:] = 0.0  # a clear band of 10 rows would be stretched 7x down to the scene's lowest sky row
    assert swap_sky(image, sky, donor, thin) is None


def test_augment_with_no_sky_swap_draws_what_it_drew_before_and_is_deterministic_with_one():
    img, sky, _ = _scene(120, 160)
    image = (np.clip(img, 0, 1) * 255).astype(np.uint8)
    donors = [(np.full((90, 120, 3), 200, np.uint8), np.where(np.arange(90)[:, None] < 60, 1.0, 0.0) * np.ones(120))]
    plain = augment(image, sky, np.random.default_rng(3))
    off = augment(image, sky, np.random.default_rng(3), donors=donors, sky_swap=0.0)
    on = augment(image, sky, np.random.default_rng(3), donors=donors, sky_swap=1.0)
    assert all(np.array_equal(x, y) for x, y in zip(plain, off))
    def blue_over_red(out):
        r, _, b = out[0][out[1].repeat(2, 0).repeat(2, 1) > 0.99].astype(float).mean(axis=0)
        return b / r

    assert blue_over_red(plain) > 2.0 and blue_over_red(on) < 1.5  # the sky laid in is the donor's grey
    again = augment(image, sky, np.random.default_rng(3), donors=donors, sky_swap=1.0)
    assert all(np.array_equal(x, y) for x, y in zip(on, again))


def test_network_layouts_build_and_the_default_is_the_shipped_one():
    """``--arch unet`` builds the shipped network (its 229,737 weights, no context branch); the probed layouts add the
    image-level context (and 1.5x the channels) and give logits at half the input size. Needs PyTorch (``.[train]``)."""
    import pytest

    torch = pytest.importorskip("torch")
    from skyrender.training.sky_net import ARCHITECTURES, build_model

    counts = {}
    for arch in ARCHITECTURES:
        model = build_model(arch)
        counts[arch] = sum(p.numel() for p in model.parameters())
        with torch.no_grad():
            assert model(torch.zeros(1, 4, 64, 96)).shape == (1, 1, 32, 48)
    assert counts["unet"] == 229737
    assert counts["unet"] < counts["unet-context"] < counts["unet-context-wide"]
    with pytest.raises(ValueError, match="unknown sky network architecture"):
        build_model("resnet")
