"""Real photographs: the fixed split, EXIF handling, DEM mosaics, the oracle fit."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from skyrender.datasets.real_photos import SPLIT_FILE, dev_fold_of, load_split, local_km, make_split, photo_items, places
from skyrender.features.photo_io import exif_fov, load_photo

from .conftest import DATA, data_path


def test_the_committed_split_keeps_places_apart_and_holds_out_the_scored_photos():
    with open(SPLIT_FILE) as f:
        photos = json.load(f)["photos"]
    sides_of_place: dict[str, set] = {}
    for v in photos.values():
        sides_of_place.setdefault(v["place"], set()).add(v["side"])
    assert all(len(s) == 1 for s in sides_of_place.values())  # no place on two sides
    assert all(v["side"] == "heldout" for k, v in photos.items() if k.split("/")[0] in ("web", "geopose3k"))
    sides = [v["side"] for k, v in photos.items() if k.startswith("ch1/")]
    assert sides.count("validation") >= 50 and sides.count("train") >= 50


def test_the_dev_folds_deal_whole_places_and_cover_the_dev_side_evenly():
    with open(SPLIT_FILE) as f:
        photos = json.load(f)["photos"]
    fold = dev_fold_of()
    assert set(fold) == {k for k, v in photos.items() if v["side"] == "dev"}
    folds_of_place: dict[str, set] = {}
    for key, k in fold.items():
        folds_of_place.setdefault(photos[key]["place"], set()).add(k)
    assert all(len(s) == 1 for s in folds_of_place.values())  # a place never in both folds
    for set_name in ("ch1", "web_train"):  # each set in both folds, about half each
        counts = np.bincount([k for key, k in fold.items() if key.startswith(set_name + "/")], minlength=2)
        assert counts.min() >= 0.4 * counts.sum()


def test_no_validation_camera_stands_within_two_km_of_a_training_camera():
    items = [it for it in photo_items(str(data_path("photos"))) if it.key.startswith("ch1/")]
    split = load_split()
    xy = local_km(np.array([it.lat for it in items]), np.array([it.lon for it in items]))
    train = np.array([split[it.key] == "train" for it in items])
    d = np.hypot(*(xy[train][:, None, :] - xy[~train][None, :, :]).transpose(2, 0, 1))
    assert d.min() > 2.0
    assert make_split(photo_items(str(data_path("photos"))))["photos"] == json.load(open(SPLIT_FILE))["photos"]


def test_places_chain_cameras_within_the_link_distance():
    lat = np.array([46.0, 46.0, 46.0, 46.5])
    lon = np.array([7.0, 7.02, 7.04, 7.0])  # 1.5 km steps, then 55 km north
    assert places(lat, lon, 2.0).tolist() == [0, 0, 0, 1]
    assert places(lat, lon, 1.0).tolist() == [0, 1, 2, 3]


def _jpeg_with_exif(path, upright_rgb, orientation, f35=None):
    from PIL import ExifTags, Image

    # store the pixels so that applying ``orientation`` turns them upright
    turns = {1: 0, 3: 2, 6: 1, 8: 3}[orientation]
    stored = np.rot90(upright_rgb, turns)
    im = Image.fromarray(np.ascontiguousarray(stored))
    exif = im.getexif()
    exif[0x0112] = orientation
    if f35:
        exif.get_ifd(ExifTags.IFD.Exif)[0xA405] = f35
    im.save(path, exif=exif, quality=95)


@pytest.mark.parametrize("orientation", [1, 3, 6, 8])
def test_exif_orientation_is_applied_on_load(orientation, tmp_path):
    upright = np.zeros((40, 60, 3), np.uint8)
    upright[:10] = (230, 20, 20)  # red sky band on top of the upright photo
    upright[:, :6] = (20, 20, 230)  # blue strip on its left
    path = tmp_path / f"o{orientation}.jpg"
    _jpeg_with_exif(str(path), upright, orientation)
    img = load_photo(path)
    assert img.shape == (40, 60, 3)
    assert img[2, 30, 0] > 200 and img[2, 30, 2] < 60  # red on top
    assert img[30, 2, 2] > 200  # blue on the left


def test_exif_35mm_focal_length_gives_the_upright_horizontal_fov(tmp_path):
    upright = np.full((300, 400, 3), 128, np.uint8)
    for orientation in (1, 6):
        path = tmp_path / f"f{orientation}.jpg"
        _jpeg_with_exif(str(path), upright, orientation, f35=26)
        f_px = 26 * np.hypot(400, 300) / np.hypot(36, 24)
        assert exif_fov(str(path)) == pytest.approx(np.degrees(2 * np.arctan(400 / (2 * f_px))), abs=1e-6)
    plain = tmp_path / "plain.png"
    import cv2

    cv2.imwrite(str(plain), upright)
    assert exif_fov(str(plain)) is None


def test_localize_auto_preset_tells_camera_photos_from_renders(tmp_path):
    from skyrender.features.photo_io import is_camera_photo

    img = np.full((30, 40, 3), 128, np.uint8)
    _jpeg_with_exif(str(tmp_path / "phone.jpg"), img, 1, f35=26)
    import cv2

    cv2.imwrite(str(tmp_path / "render.png"), img)
    cv2.imwrite(str(tmp_path / "export.jpeg"), img)  # a JPEG is a photo even without EXIF
    assert is_camera_photo(str(tmp_path / "phone.jpg")) and is_camera_photo(str(tmp_path / "export.jpeg"))
    assert not is_camera_photo(str(tmp_path / "render.png"))


def test_photo_models_are_cached_apart_from_render_models():
    from skyrender.dem import load_dem
    from skyrender.model import ModelParams, model_cache_key

    dem = load_dem("builtin:jacksboro")
    assert model_cache_key(dem) == dem.fingerprint()
    photo = model_cache_key(dem, ModelParams.for_photos())
    assert photo.startswith(dem.fingerprint() + "-") and photo == model_cache_key(dem, ModelParams.for_photos())


def test_a_probe_of_model_parameters_is_cached_apart_and_refuses_unknown_fields(capsys):
    """``--model-set`` of bench-real, the candidates diagnostic and localize_fit: the photo preset's model
    with some fields set, under a cache key of its own; an unknown field is a one-line refusal (status 2)."""
    from skyrender.benchmarks.real_localize import main, model_overrides
    from skyrender.dem import load_dem
    from skyrender.model import ModelParams, model_cache_key

    assert model_overrides(None) is None
    probe = model_overrides('{"horizons": {"spacing": 125.0}}')
    assert probe.horizons.spacing == 125.0
    assert probe.horizons.near_m == ModelParams.for_photos().horizons.near_m  # the rest is the photo preset's
    dem = load_dem("builtin:jacksboro")
    assert model_cache_key(dem, probe) != model_cache_key(dem, ModelParams.for_photos())
    data_path("photos", "ch1")
    assert main(["--side", "dev", "--photos", "none", "--model-set", '{"horizons": {"spacin": 1}}']) == 2
    assert "spacin" in capsys.readouterr().out
    # a photo key that names no photo of the side is refused too, not run as an empty benchmark
    assert main(["--side", "dev", "--photos", "IMG_4922_01024"]) == 2
    assert "IMG_4922_01024" in capsys.readouterr().out


def test_a_ch1_mask_given_as_a_terrain_mask_is_that_photos_true_skyline(tmp_path):
    """``localize --terrain-mask`` takes the CH1 and GeoPose3K masks as they come (white = terrain): the skyline it gives
    is the one the benchmarks score against, and the same mask inverted through ``--sky-mask`` gives it too."""
    import cv2

    from skyrender.features import given_skyline
    from skyrender.viz import write_image

    data_path("photos", "ch1")
    item = next(it for it in photo_items(str(DATA / "photos")) if it.key == "ch1/DSCF3435_01024")
    H, W = load_photo(item.image_path).shape[:2]
    truth = item.truth_skyline()
    from_terrain = given_skyline(W, H, terrain_mask_path=item.truth_path)
    np.testing.assert_array_equal(from_terrain, truth)
    assert np.isfinite(truth).mean() > 0.9
    write_image(tmp_path / "sky.png", 255 - cv2.imread(item.truth_path))
    np.testing.assert_array_equal(given_skyline(W, H, sky_mask_path=tmp_path / "sky.png"), truth)


def _write_geotiff(path, z, west, north, step):
    import rasterio
    from affine import Affine

    with rasterio.open(path, "w", driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype="float32",
                       crs="EPSG:4326", transform=Affine(step, 0, west, 0, -step, north), nodata=-32768) as dst:
        dst.write(z.astype(np.float32), 1)


def test_a_mosaic_of_two_adjacent_tiles_equals_the_same_part_of_one_larger_grid(tmp_path):
    from skyrender.dem import load_dem

    # posts every 1/120 deg; the tiles share their edge column, as SRTM tiles do
    step = 1.0 / 120
    rng = np.random.default_rng(0)
    z = 1000 + np.cumsum(np.cumsum(rng.normal(0, 2, (121, 241)), 0), 1)
    half = step / 2  # cell-as-area convention: the grid's outer corner is half a post out
    _write_geotiff(tmp_path / "big.tif", z, 7.0 - half, 47.0 + half, step)
    _write_geotiff(tmp_path / "west.tif", z[:, :121], 7.0 - half, 47.0 + half, step)
    _write_geotiff(tmp_path / "east.tif", z[:, 120:], 8.0 - half, 47.0 + half, step)
    big = load_dem(tmp_path / "big.tif")
    for spec in ([tmp_path / "west.tif", tmp_path / "east.tif"], f"{tmp_path / 'west.tif'},{tmp_path / 'east.tif'}"):
        mosaic = load_dem(spec)
        assert mosaic.crs == big.crs and mosaic.shape == big.shape
        assert mosaic.transform.almost_equals(big.transform)
        np.testing.assert_allclose(mosaic.elevation, big.elevation, atol=1e-3)
    os.remove(tmp_path / "big.tif")
    folder = load_dem(tmp_path)  # a directory of tiles
    np.testing.assert_allclose(folder.elevation, big.elevation, atol=1e-3)


def test_mosaic_errors_name_the_problem(tmp_path):
    from skyrender.dem import load_dem
    from skyrender.errors import InputError

    with pytest.raises(InputError, match="not found"):
        load_dem(f"{tmp_path / 'a.tif'},{tmp_path / 'b.tif'}")
    with pytest.raises(InputError, match="no .hgt"):
        load_dem(tmp_path)


def test_a_window_between_posts_reads_the_tiles_own_posts_in_either_order(tmp_path):
    """``--dem-bounds`` whose corners fall between posts (as a photo's lon/lat +- a radius does): the window is
    grown to whole cells, so the DEM holds the tiles' own posts where they stand, whichever tile comes first
    (rasterio.merge on the raw corners moved every post up to half a cell, and one tile against the other)."""
    import rasterio
    from affine import Affine

    from skyrender.dem import load_dem

    rng = np.random.default_rng(2)
    z = 1000 + np.cumsum(np.cumsum(rng.normal(0, 2, (80, 161)), 0), 1)
    for name, cols, west in (("a.tif", slice(0, 81), 400_000.0), ("b.tif", slice(80, 161), 408_000.0)):
        with rasterio.open(tmp_path / name, "w", driver="GTiff", width=81, height=80, count=1, dtype="float64",
                           crs="EPSG:32632", transform=Affine(100, 0, west, 0, -100, 5_200_000)) as dst:
            dst.write(z[:, cols], 1)
    window = (401_234.5, 5_193_456.7, 412_345.6, 5_198_765.4)  # W,S,E,N between posts
    for order in (["a.tif", "b.tif"], ["b.tif", "a.tif"]):
        dem = load_dem([tmp_path / name for name in order], bounds=window)
        assert dem.crs == "EPSG:32632" and dem.transform.a == 100.0
        assert (dem.transform.c, dem.transform.f) == (401_200.0, 5_198_800.0)  # grown outward to whole cells
        np.testing.assert_array_equal(dem.elevation, z[12:66, 12:124])


def test_a_folder_of_mixed_tiles_mosaics_those_of_one_kind_reaching_the_window(tmp_path, monkeypatch, capsys):
    """A folder as ``../shared/data/dem`` is: two adjacent tiles, a finer tile over part of them, a tile in UTM, a
    grid with no CRS and a tile far away. With a window, the tiles outside it are left out silently, the finer one
    and the grid with a warning (one line from the command line), and the mosaic is the two tiles'; tiles listed
    one by one are merged or refused, never chosen among; a mosaic too large to hold is refused before it is read."""
    import warnings

    import rasterio
    from affine import Affine

    from skyrender import cli
    from skyrender.dem import io as dem_io
    from skyrender.dem import load_dem
    from skyrender.dem.io import SkippedTilesWarning
    from skyrender.errors import InputError

    step, half = 1.0 / 120, 1.0 / 240
    rng = np.random.default_rng(1)
    z = 1000 + np.cumsum(np.cumsum(rng.normal(0, 2, (121, 241)), 0), 1)
    _write_geotiff(tmp_path / "west.tif", z[:, :121], 7.0 - half, 47.0 + half, step)
    _write_geotiff(tmp_path / "east.tif", z[:, 120:], 8.0 - half, 47.0 + half, step)
    _write_geotiff(tmp_path / "fine.tif", np.full((61, 61), 1500.0), 7.4, 46.8, step / 3)
    _write_geotiff(tmp_path / "far.tif", z[:, :121], 86.0 - half, 28.0 + half, step)
    with rasterio.open(tmp_path / "utm.tif", "w", driver="GTiff", width=50, height=50, count=1, dtype="float32",
                       crs="EPSG:32632", transform=Affine(30, 0, 400_000, 0, -30, 5_200_000)) as dst:
        dst.write(np.full((50, 50), 800.0, np.float32), 1)
    # a grid with no CRS whose metres, read as degrees, cover the whole window
    (tmp_path / "grid.asc").write_text("ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 30\nNODATA_value -9999\n"
                                       + "1 2 3\n" * 3)
    window = (7.2, 46.2, 8.6, 46.8)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        folder = load_dem(tmp_path, bounds=window)
    skipped = [str(w.message) for w in caught if issubclass(w.category, SkippedTilesWarning)]
    assert len(skipped) == 1 and "fine.tif" in skipped[0] and "grid.asc" in skipped[0] and "far.tif" not in skipped[0]
    pair = load_dem([tmp_path / "west.tif", tmp_path / "east.tif"], bounds=window)
    assert folder.shape == pair.shape and folder.transform.almost_equals(pair.transform)
    np.testing.assert_allclose(folder.elevation, pair.elevation, atol=1e-3)
    assert "mosaic of 2 tiles" in folder.name
    with pytest.raises(InputError, match="different cell sizes"):
        load_dem([tmp_path / "west.tif", tmp_path / "fine.tif"], bounds=window)
    with pytest.raises(InputError, match="different CRSs"):
        load_dem([tmp_path / "west.tif", tmp_path / "utm.tif"])
    with pytest.raises(InputError, match="no tile reaches"):
        load_dem(tmp_path, bounds=(100.0, 10.0, 101.0, 11.0))
    # without a window the folder's most common kind is west, east and far, 79 degrees of longitude and 19 of
    # latitude apart: 23 M cells of these coarse posts, billions of SRTM's
    monkeypatch.setattr(dem_io, "MAX_MOSAIC_CELLS", 500_000)
    with pytest.raises(InputError, match=r"23,\d\d\d,\d\d\d cells \(at most 500,000\).*--dem-bounds"):
        load_dem(tmp_path)
    assert load_dem(tmp_path, bounds=window).shape == pair.shape
    monkeypatch.undo()
    out = tmp_path / "t.ply"
    assert cli.main(["mesh", str(tmp_path), "--dem-bounds", ",".join(map(str, window)), "--out", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("skyrender: warning:") and "fine.tif" in err[0]


def test_the_oracle_fit_of_a_ch1_photo_at_its_true_position():
    from skyrender.diagnostics.oracle import oracle_for_photo

    data_path("dem", "N46E009.hgt")
    item = next(it for it in photo_items(str(DATA / "photos")) if it.key == "ch1/2011-04-30_18-40-20_01024")
    row = oracle_for_photo(item, radius_km=25.0)
    # measured: median 3.4 px, camera tilted up ~14 deg at the ridge above it
    assert row["median_px"] < 5.0
    assert 8.0 < row["tilt"] < 20.0
    assert sum(v["columns"] for v in row["by_distance"].values()) > 900


@pytest.fixture(scope="module")
def validation_extractions():
    """(column errors, confidences with truth) of the photo extractor on every validation photo."""
    from skyrender.benchmarks.skyline_photos import column_errors
    from skyrender.datasets.real_photos import items_on_side
    from skyrender.features import SkylineParams, extract_skyline

    items = items_on_side("validation", str(data_path("photos")))
    out = []
    for it in items:
        truth = it.truth_skyline()
        result = extract_skyline(load_photo(it.image_path), SkylineParams(method="select"))
        out.append((column_errors(result.skyline, truth), result.confidence[np.isfinite(truth)]))
    return out


def test_the_photo_extractor_on_photos_it_was_not_fitted_on(validation_extractions):
    from skyrender.benchmarks.skyline_photos import meets_target

    within5 = np.array([np.mean(e <= 5) for e, _ in validation_extractions])
    met = np.mean([meets_target(np.median(e), w) for (e, _), w in zip(validation_extractions, within5)])
    assert len(validation_extractions) == 80
    # make bench-skyline (validation side, the 12,000-step network, the EM's smaller budget): select mean
    # within 5 px 90.2 %, the target met on 48 of 80 photos (60 %), where hybrid alone gave 87.7 % and 43,
    # the network alone 80.6 % and 30; the issue's goal (97 %, 90 %) is not reached yet
    assert within5.mean() >= 0.885
    assert met >= 0.57


def test_confident_columns_are_right_more_often(validation_extractions):
    e = np.concatenate([e for e, _ in validation_extractions])
    c = np.concatenate([c for _, c in validation_extractions])
    sure, unsure = e[c >= 0.5], e[c < 0.5]
    # measured (select, the 12,000-step network): 92.1 % of confident columns within 5 px, 42.4 % of the others
    assert np.mean(sure <= 5) > np.mean(unsure <= 5) + 0.4
    assert np.mean(sure <= 5) >= 0.90


def test_a_twelve_megapixel_photo_is_extracted_on_a_reduced_copy_in_full_coordinates():
    import cv2

    from skyrender.benchmarks.skyline_photos import column_errors
    from skyrender.datasets.real_photos import items_on_side
    from skyrender.features import SkylineParams, extract_skyline

    it = next(i for i in items_on_side("validation", str(data_path("photos"))) if i.key == "ch1/DSCF3435_01024")
    image = load_photo(it.image_path)
    big = cv2.resize(image, (4096, 3072), interpolation=cv2.INTER_CUBIC)
    params = SkylineParams(method="hybrid")
    result = extract_skyline(big, params)
    assert result.skyline.shape == (4096,) and result.sky_probability.shape == (3072, 4096)
    assert result.confidence.shape == (4096,)
    # the same as the reduced copy's skyline, scaled up (within the full-resolution band refinement)
    w, h = params.reduced_width, params.reduced_width * 3 // 4
    reduced = extract_skyline(cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA), params).skyline
    up = np.interp((np.arange(4096) + 0.5) * w / 4096 - 0.5, np.arange(w), reduced) * 4096 / w
    assert np.nanmedian(np.abs(result.skyline - up)) <= 2.0
    # and near the truth: measured 1.26 px median at the photo's own scale (the 1024-wide photo itself 0.72 px), all within 5 px
    e = column_errors(result.skyline, np.repeat(it.truth_skyline(), 4) * 4) / 4
    assert np.median(e) <= 1.5 and np.mean(e <= 5) >= 0.95


def test_a_ch1_validation_photo_is_localized_within_a_kilometre():
    """End to end on a photo never fitted on (validation side), with the photo presets:
    the learned skyline, the far-horizon search over tilts, the margin confidence.
    ``make bench-real`` reports the whole validation side."""
    from skyrender.datasets.real_photos import items_on_side
    from skyrender.diagnostics.oracle import dem_around
    from skyrender.localizer import LocalizeParams, localize
    from skyrender.model import ModelParams, build_model
    from skyrender.render import Terrain

    data_path("dem", "N46E007.hgt")
    item = next(i for i in items_on_side("validation", str(DATA / "photos")) if i.key == "ch1/DSCF3435_01024")
    dem = dem_around(item.lat, item.lon, radius_km=20.0)
    terrain = Terrain(dem)
    model = build_model(dem, ModelParams.for_photos(), terrain=terrain)
    image = load_photo(item.image_path)
    fov = float(np.degrees(2 * np.arctan(image.shape[1] / (2 * item.focal_px))))
    result = localize(image, model, 2.0, fov, terrain=terrain, params=LocalizeParams.for_photos())
    x, y = (float(v) for v in dem.from_lonlat(item.lon, item.lat))
    assert result.localized
    assert np.hypot(result.pose[0] - x, result.pose[1] - y) < 1000.0


def test_the_true_skyline_diagnostic_hands_the_localizer_the_mask_as_an_extraction():
    """``bench-real --true-skyline``: the photo's true skyline, every column trusted, P(sky) 1 above it."""
    from skyrender.benchmarks.real_localize import true_extraction

    data_path("photos", "ch1")
    item = next(i for i in photo_items(str(DATA / "photos")) if i.key.startswith("ch1/"))
    truth = item.truth_skyline()
    H = int(np.nanmax(truth)) + 40
    found = true_extraction(item, H)
    np.testing.assert_array_equal(found.skyline, truth)
    assert (found.confidence == 1).all() and found.sky_probability.shape == (H, len(truth))
    c = int(np.flatnonzero(np.isfinite(truth))[0])
    column = found.sky_probability[:, c]
    assert column[: int(np.ceil(truth[c]))].all() and not column[int(np.ceil(truth[c])):].any()


def test_column_weights_and_the_recall_rank_of_the_diagnostic():
    """Pure helpers of the real-photo path: column weights from the per-column confidence
    (floored at 0.05, raised to a power) and the diagnostic's rank of the first pose near
    the truth."""
    from skyrender.diagnostics.candidates import first_rank
    from skyrender.localizer.pipeline import column_weights

    w = column_weights(np.array([0.0, 0.5, 1.0]), power=3.0)
    np.testing.assert_allclose(w, [0.05**3, 0.125, 1.0])
    order = np.array([2, 0, 1])  # best first
    distance = np.array([300.0, 2000.0, 1500.0])
    assert first_rank(order, distance, 500.0) == 2  # pose 0, ranked second
    assert first_rank(order, distance, 1600.0) == 1
    assert first_rank(order, distance, 100.0) is None


def test_bench_real_retables_a_run_of_one_fov_mode(tmp_path):
    """``--retable`` of a run made with ``--fov unknown`` only summarises that mode (it raised on
    the empty known-fov summary); a report of rows merged from two runs says so in its header."""
    from skyrender.benchmarks.real_localize import main

    data_path("photos", "ch1")
    rows = [{"photo": f"ch1/p{k}", "fov_mode": "unknown", "status": "localized", "confidence": 0.99,
             "seconds": 100.0 + k, "error_m": 150.0 * (k + 1)} for k in range(2)]
    with open(tmp_path / "bench-real-validation-t.json", "w") as f:
        json.dump({"commit": "abc", "cpus": 2, "side": "validation", "photos": rows}, f)
    assert main(["--side", "validation", "--tag", "t", "--out", str(tmp_path), "--retable"]) == 0
    text = (tmp_path / "bench-real-validation-t.txt").read_text()
    assert "unknown fov: 2 photos; within 100 m 0 %, 250 m 50 %, 1 km 100 %" in text
    assert "\nknown fov" not in text
    # rows merged from two runs (one mode's code unchanged between them): the header says where each came from
    with open(tmp_path / "bench-real-validation-t.json", "w") as f:
        json.dump({"commit": "abc", "cpus": 2, "side": "validation", "photos": rows,
                   "merged": {"fov unknown": "the run at def"}}, f)
    assert main(["--side", "validation", "--tag", "t", "--out", str(tmp_path), "--retable"]) == 0
    head = (tmp_path / "bench-real-validation-t.txt").read_text().splitlines()[0]
    assert head == "commit abc, 2 CPUs (versions not recorded), side validation; rows merged: fov unknown: the run at def"


def test_bench_real_rescores_a_run_under_another_fit_and_refuses_a_bad_one(tmp_path, capsys):
    """``--retable --rescore --fit FIT.json``: the rows judged by that fit's logit and thresholds (the
    poses kept), recorded in the report; a fit file that is not one: a one-line message and exit 2."""
    from skyrender.benchmarks.real_localize import main

    data_path("photos", "ch1")
    poses = [[0, 0, 2, 0, 0, 0, 800, 1.0], [5000, 0, 2, 0, 0, 0, 800, 2.0]]  # margin 0.5
    rows = [{"photo": "ch1/p0", "fov_mode": "known", "status": "localized", "confidence": 0.5, "seconds": 10.0,
             "error_m": 150.0, "refined_poses": poses, "best_score": 1.0, "runner_up_score": 2.0}]
    with open(tmp_path / "bench-real-validation-t.json", "w") as f:
        json.dump({"commit": "abc", "cpus": 2, "side": "validation", "photos": rows}, f)
    fit = tmp_path / "fit.json"
    fit.write_text(json.dumps({"logit": [-3.0, 2.0], "min_confidence": 0.9, "runner_up_m": 1000.0}))
    args = ["--side", "validation", "--tag", "t", "--out", str(tmp_path), "--retable", "--rescore", "--fit", str(fit)]
    assert main(args) == 0
    report = json.loads((tmp_path / "bench-real-validation-t.json").read_text())
    assert report["photos"][0]["status"] == "abstained"  # logistic(-3 + 2 * 0.5) = 0.12 < 0.9
    assert report["photos"][0]["withheld_error_m"] == 150.0
    assert report["rescored"]["logit"] == [-3.0, 2.0] and report["rescored"]["min_confidence"] == 0.9
    fit.write_text("{}")
    assert main(args) == 2
    out = capsys.readouterr().out.strip().splitlines()
    assert out[-1].startswith("--fit: cannot read a photo-confidence fit from")


def test_a_photo_s_dem_window_does_not_depend_on_the_other_photos_of_the_run():
    """``real_localize.places_of``: a place's centre (and so its DEM window and model) is the mean of all the data's
    photos taken there, whether the run holds one of them or the whole side (a run of one place06 photo had a window
    0.1 deg off, and another answer)."""
    from skyrender.benchmarks.real_localize import place_window, places_of
    from skyrender.datasets.real_photos import items_on_side

    data_path("photos", "ch1")
    side = [it for it in items_on_side("validation") if it.key.startswith("ch1/")]
    place_of, whole = places_of(side)
    for it in side[::7]:
        _, alone = places_of([it])
        assert alone == {place_of[it.key]: whole[place_of[it.key]]}
    lats = [it.lat for it in side if place_of[it.key] == "ch1/place06"]
    assert len(lats) > 1 and whole["ch1/place06"][0] == pytest.approx(np.mean(lats))
    assert place_window(*places_of(side[:1])[1][place_of[side[0].key]]) == place_window(*whole[place_of[side[0].key]])


def test_a_benchmark_run_is_summarised_place_by_place():
    """Each run's table says, per place of the split, how many photos ended within 250 m and 1 km,
    withheld answers included: a change that helps one place only shows as such."""
    from skyrender.benchmarks.real_localize import by_place, table

    rows = [{"photo": "a1", "error_m": 100.0}, {"photo": "a2", "error_m": 600.0}, {"photo": "b1", "withheld_error_m": 200.0},
            {"photo": "b2", "error_m": 5e4}, {"photo": "c1"}]
    places = by_place(rows, {"a1": "ch1/place11", "a2": "ch1/place11", "b1": "ch1/place03", "b2": "ch1/place03"})
    assert places == {"?": {"photos": 1, "within_250m": 0, "within_1000m": 0},
                      "ch1/place03": {"photos": 2, "within_250m": 1, "within_1000m": 1},
                      "ch1/place11": {"photos": 2, "within_250m": 1, "within_1000m": 2}}
    text = table({"photos": [], "summary": {}, "by_place": {"known": places}})
    assert text.endswith("known fov by place (within 250 m / 1 km of photos, answered or withheld): "
                         "? 0 / 0 of 1, place03 1 / 1 of 2, place11 1 / 2 of 2")


def test_a_benchmark_run_says_how_often_each_confidence_was_right():
    """``real_localize.calibration``: every answer, given or withheld (its best refined pose against the truth),
    binned by confidence, with the share within 1 km per bin and the Brier score; rows without poses left out."""
    from skyrender.benchmarks.real_localize import calibration, table

    def row(conf, x):
        return {"photo": "p", "confidence": conf, "truth_xy": [0.0, 0.0],
                "refined_poses": [[x, 0, 0, 0, 0, 0, 800, 1.0], [9e4, 0, 0, 0, 0, 0, 800, 0.5 + 1.0]]}

    rows = [row(0.1, 5e4), row(0.2, 300.0), row(0.97, 200.0), row(0.999, 100.0), row(0.999, 2e4), {"confidence": 0.5}]
    cal = calibration(rows)
    assert cal["photos"] == 5 and [b["photos"] for b in cal["bins"]] == [2, 0, 0, 1, 2]
    assert cal["bins"][0]["share_right"] == 0.5 and cal["bins"][0]["mean_confidence"] == pytest.approx(0.15)
    assert cal["bins"][4]["share_right"] == 0.5 and cal["bins"][1]["share_right"] is None
    assert cal["brier"] == pytest.approx(np.mean([0.1 ** 2, 0.8 ** 2, 0.03 ** 2, 0.001 ** 2, 0.999 ** 2]))
    text = table({"photos": [], "summary": {}, "calibration": {"known": cal}})
    assert "known fov calibration" in text and "0.99: 2, 1.00, 0.50" in text and f"Brier {cal['brier']:.3f}" in text


def test_a_recall_interval_resamples_whole_places_not_photos():
    """``evaluate.place_interval``: photos of one place succeed or fail together, so the interval over places is wider
    than the one over photos of the same outcomes; it holds the observed share, is the same for the same seed, and
    is the share itself with one place or one outcome. ``real_localize.place_intervals`` gives it per recall radius, and the table
    prints it."""
    from skyrender.benchmarks.real_localize import place_intervals, table
    from skyrender.evaluate import place_interval

    outcome = np.r_[np.ones(20), np.zeros(4), np.ones(3), np.zeros(13)]  # a place of 20 found, others mostly not
    places = np.r_[np.zeros(20), np.repeat(np.arange(1, 6), 4)]
    lo, hi = place_interval(outcome, places)
    photo_lo, photo_hi = place_interval(outcome, np.arange(len(outcome)))
    assert lo <= outcome.mean() <= hi and photo_lo <= outcome.mean() <= photo_hi
    assert hi - lo > 1.5 * (photo_hi - photo_lo)  # resampling photos alone would claim far too much
    assert place_interval(outcome, places) == (lo, hi)
    assert place_interval(outcome, np.zeros(len(outcome))) == (outcome.mean(), outcome.mean())
    assert place_interval(np.ones(6), [0, 0, 1, 1, 2, 2]) == (1.0, 1.0)

    rows = [{"photo": f"p{i}", "error_m": 50.0 if i < 10 else 600.0} for i in range(16)] + [{"photo": "q", "status": "abstained"}]
    place_of = {f"p{i}": ("a" if i < 10 else f"b{i}") for i in range(16)}
    ci = place_intervals(rows, place_of)
    assert ci["places"] == 8 and ci["recall_1000m"][0] < 16 / 17 <= ci["recall_1000m"][1]
    assert ci["recall_100m"][0] <= 10 / 17 <= ci["recall_100m"][1] and ci["recall_100m"][1] - ci["recall_100m"][0] > 0.3
    text = table({"photos": [], "summary": {}, "intervals": {"known": ci}})
    assert "known fov, 95 % interval with the 8 places resampled whole: within 100 m" in text


def test_bench_real_counts_the_truth_among_the_places_localize_lists(tmp_path, capsys):
    """``real_localize.places_offered``: how often the true position lies within 1 km of the first, or of one of
    the first 3, distinct places refined (the answer's first, given or withheld: what ``localize --candidates``
    lists); a row without refined poses is a miss. ``--retable`` prints it, and of a run that is not there says so
    in one line (exit 2) instead of a traceback."""
    from skyrender.benchmarks.real_localize import main, places_offered, table

    def row(photo, poses):  # poses: (x, score) along one axis, 2 m up, the same view
        return {"photo": photo, "fov_mode": "known", "status": "abstained", "confidence": 0.3, "seconds": 9.0,
                "truth_xy": [0.0, 0.0], "refined_poses": [[x, 0, 2, 0, 0, 0, 900, s] for x, s in poses]}

    rows = [row("a", [(300, 1.0), (20_000, 1.2)]),  # right first
            row("b", [(20_000, 1.0), (20_400, 1.1), (500, 1.3)]),  # right third pose, second place (20.4 km is place 1)
            row("c", [(20_000, 1.0), (30_000, 1.1), (40_000, 1.2), (600, 1.3)]),  # right, but the fourth place
            row("d", []), {"photo": "e", "fov_mode": "known", "status": "abstained", "confidence": 0.0, "seconds": 1.0}]
    offered = places_offered(rows)
    assert offered == {"photos": 5, "right_m": 1000.0, "within": {"1": 1, "3": 2}}
    assert places_offered(rows, (1, 4))["within"] == {"1": 1, "4": 3}
    assert places_offered(rows, (1,), right_m=200.0)["within"] == {"1": 0}
    text = table({"photos": [], "summary": {}, "places_offered": {"known": offered}})
    assert "the truth within 1 km of the first on 1 of 5, of one of the first 3 on 2" in text

    data_path("photos", "ch1")
    assert main(["--side", "validation", "--tag", "none", "--out", str(tmp_path), "--retable"]) == 2
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("--retable: no finished run bench-real-validation-none.json")
    with open(tmp_path / "bench-real-validation-t.json", "w") as f:
        json.dump({"commit": "abc", "cpus": 2, "side": "validation", "photos": [dict(r, photo=f"ch1/{r['photo']}")
                                                                                for r in rows]}, f)
    assert main(["--side", "validation", "--tag", "t", "--out", str(tmp_path), "--retable"]) == 0
    report = json.loads((tmp_path / "bench-real-validation-t.json").read_text())
    assert report["places_offered"]["known"]["within"] == {"1": 1, "3": 2}


def test_the_extractor_benchmark_gives_its_shares_with_intervals_over_places():
    """``skyline_photos.summary`` with the photos' places: a CH1 place's photos are resampled together, a photo
    without a place (a Web photo) alone; without places, no interval."""
    from skyrender.benchmarks.skyline_photos import summary

    def row(key, median, within5):
        return {"photo": key, "m": {"median": median, "within5": within5, "seconds": 0.5}}

    rows = [row(f"ch1/a{i}", 0.5, 1.0) for i in range(8)] + [row(f"ch1/b{i}", 3.0, 0.7) for i in range(4)] + \
        [row("web/w1", 0.4, 0.99), row("web/w2", 9.0, 0.2)]
    place_of = {**{f"ch1/a{i}": "ch1/place01" for i in range(8)}, **{f"ch1/b{i}": "ch1/place02" for i in range(4)}}
    s = summary(rows, "m", place_of)
    assert s["met"] == 9 and s["places"] == 4
    lo, hi = s["met_share_interval"]
    assert lo < 9 / 14 < hi and hi - lo > 0.3
    assert s["mean_within5_interval"][0] < s["mean_within5"] < s["mean_within5_interval"][1]
    assert "met_share_interval" not in summary(rows, "m")


def test_bench_skyline_retables_a_run_with_the_intervals(tmp_path):
    """``bench-skyline --retable`` rewrites a run's text from its JSON, the summaries made again with the places'
    intervals (a run from before them gains them), and refuses a folder without a run, with exit status 2."""
    import json

    from skyrender.benchmarks.skyline_photos import main

    def row(key, within5):
        return {"photo": key, "width": 1024, "height": 768, "unseen": 0.0,
                "select": {"median": 0.5 if within5 > 0.95 else 4.0, "within5": within5, "seconds": 0.8}}

    timing = {"seconds": 0.8, "width": 1024, "height": 768, "median_px_at_1024": 0.5}
    report = {"commit": "abc", "cpus": 2, "methods": ["select"],
              "sides": {"validation": {"photos": [row("ch1/a", 1.0), row("ch1/b", 0.5), row("web_train/web050", 1.0)],
                                       "summary": {}, "confidence": None}},
              "speed": {"method": "select", "photo": "ch1/a", "1024": timing, "12mp": {**timing, "width": 4096}},
              "mixture_fit": {"photo": "ch1/a", "samples": 12000, "ours": {"seconds": 0.05},
                              "scikit_learn": {"seconds": 0.15}, "max_mean_difference": 1e-12}}
    (tmp_path / "bench-skyline.json").write_text(json.dumps(report))
    assert main(["--retable", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "bench-skyline.txt").read_text()
    assert "met on 2 of 3 (67 %)" in text and "95 % interval with the 3 places resampled whole: target met" in text
    stored = json.loads((tmp_path / "bench-skyline.json").read_text())
    assert stored["sides"]["validation"]["summary"]["select"]["places"] == 3
    assert main(["--retable", "--out", str(tmp_path / "none")]) == 2


def test_bench_skyline_times_the_first_extractor_when_the_baseline_comes_first(tmp_path):
    """A ``bench-skyline`` run listing Otsu first scores it and times ``select`` (the speed line once timed the
    first method and stopped with a ValueError on Otsu)."""
    from skyrender.benchmarks.skyline_photos import main

    assert main(["--data", str(data_path("photos")), "--sides", "heldout", "--limit", "1", "--methods", "otsu",
                 "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "bench-skyline.json").read_text())
    assert report["speed"]["method"] == "select" and report["speed"]["1024"]["seconds"] > 0
    assert report["sides"]["heldout"]["summary"]["otsu"]["photos"] == 1


def test_an_extractor_run_is_compared_with_the_committed_benchmark_photo_by_photo():
    """``skyline_photos.unchanged_report``: the identity check after a change counts the photos whose median
    and share within 5 px are the committed ones, and names each that moved."""
    from skyrender.benchmarks.skyline_photos import unchanged_report

    bench = {"commit": "abc", "sides": {"validation": {"photos": [
        {"photo": "a", "select": {"median": 0.5, "within5": 1.0}},
        {"photo": "b", "select": {"median": 2.5, "within5": 0.9}}]}}}
    now = {"a": {"median": 0.5, "within5": 1.0}, "b": {"median": 2.4, "within5": 0.9}}
    report = unchanged_report(now, bench, sides=("validation",))
    assert report.splitlines()[0] == "bench-skyline.json at abc: 1 of 2 photos with the same median and share within 5 px"
    assert report.splitlines()[1].startswith("  b: ") and len(report.splitlines()) == 2
    now["b"]["median"] = 2.5
    report = unchanged_report(now, bench, sides=("validation",))
    assert report.endswith("2 of 2 photos with the same median and share within 5 px")
