"""The command line (README, Command line): outputs, JSON, and one-line errors with exit 2."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from skyrender.cli import main
from skyrender.io import load_skyline

RENDER = ["render", "--height", "2", "--pan", "40", "--tilt", "4", "--swing", "0", "--fov", "60",
          "--size", "160x120"]


def builtin_args(valley_view):
    pose, _ = valley_view
    return ["--dem", "builtin:jacksboro", "--x", str(pose.x), "--y", str(pose.y)]


def test_render_writes_image_skyline_and_json(tmp_path, capsys, valley_view):
    out, sky = tmp_path / "view.png", tmp_path / "sky.npy"
    code = main(RENDER + builtin_args(valley_view) + ["--out", str(out), "--skyline-out", str(sky), "--json"])
    assert code == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)  # exactly one JSON object on stdout
    assert set(result) == {"x", "y", "z", "pan", "tilt", "swing", "fov", "width", "height", "crs"}
    assert result["crs"] == "EPSG:32616" and result["width"] == 160 and result["height"] == 120
    assert result["fov"] == pytest.approx(60)
    pose, _ = valley_view
    assert result["z"] == pytest.approx(pose.z)
    import cv2

    img = cv2.imread(str(out))
    assert img.shape == (120, 160, 3)
    skyline = load_skyline(sky)
    assert skyline.shape == (160,) and skyline.dtype == np.float64
    assert np.isfinite(skyline).mean() > 0.9


def test_render_accepts_lat_lon_and_json_skylines(tmp_path, capsys, view_dem, valley_view):
    pose, _ = valley_view
    lon, lat = view_dem.to_lonlat(pose.x, pose.y)
    out, sky = tmp_path / "view.png", tmp_path / "sky.json"
    args = RENDER + ["--dem", "builtin:jacksboro", "--lat", str(lat),
                     "--lon", str(lon), "--out", str(out), "--skyline-out", str(sky), "--json"]
    assert main(args) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["x"] == pytest.approx(pose.x, abs=1e-3) and result["y"] == pytest.approx(pose.y, abs=1e-3)
    data = json.loads(sky.read_text())
    assert len(data) == 160 and all(v is None or isinstance(v, float) for v in data)


def _bad(capsys, args):
    code = main(args)
    err = capsys.readouterr().err
    return code, err


@pytest.mark.parametrize("case", ["missing", "text", "negative_fov", "outside", "bad_size", "no_position"])
def test_bad_input_gives_one_line_and_exit_2(case, tmp_path, capsys, valley_view):
    text = tmp_path / "notes.tif"
    text.write_text("this is not a DEM\n")
    args = RENDER + builtin_args(valley_view) + ["--out", str(tmp_path / "x.png")]
    if case == "missing":
        args[args.index("--dem") + 1] = str(tmp_path / "nope.tif")
    elif case == "text":
        args[args.index("--dem") + 1] = str(text)
    elif case == "negative_fov":
        args[args.index("--fov") + 1] = "-60"
    elif case == "outside":
        args[args.index("--x") + 1] = "0"
    elif case == "bad_size":
        args[args.index("--size") + 1] = "big"
    elif case == "no_position":
        i = args.index("--x")
        del args[i : i + 4]
    code, err = _bad(capsys, args)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("skyrender: error:")
    assert "Traceback" not in err
    assert not (tmp_path / "x.png").exists()


def test_unwritable_output_is_bad_input(capsys, valley_view, tmp_path):
    args = RENDER + builtin_args(valley_view) + ["--out", str(tmp_path / "no" / "such" / "dir" / "x.png")]
    code, err = _bad(capsys, args)
    assert code == 2 and "does not exist" in err


def test_installed_console_script_exits_2_on_a_missing_dem(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "skyrender", "render", "--dem", str(tmp_path / "none.tif"),
                           "--x", "0", "--y", "0", "--height", "2", "--pan", "0", "--tilt", "0", "--swing", "0",
                           "--fov", "60", "--size", "64x48", "--out", str(tmp_path / "a.png")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.strip().count("\n") == 0 and "not found" in proc.stderr


def test_the_command_sets_its_process_defaults_before_numpy_is_imported():
    """The command's entry module turns numpy's huge-page requests off by default (a stall in
    memory compaction on kernels that defragment on madvise), keeps a value the user set, and
    imports nothing that would import numpy first (numpy reads the setting once, on import)."""
    from skyrender.__main__ import command_process_settings

    env = {}
    command_process_settings(env)
    assert env == {"NUMPY_MADVISE_HUGEPAGE": "0"}
    env = {"NUMPY_MADVISE_HUGEPAGE": "1"}
    command_process_settings(env)
    assert env == {"NUMPY_MADVISE_HUGEPAGE": "1"}
    proc = subprocess.run([sys.executable, "-c", "import sys, skyrender.__main__; print('numpy' in sys.modules)"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout.strip() == "False", proc.stderr


BUILTIN_RENDER = ["render", "--dem", "builtin:jacksboro", "--lat", "36.54386", "--lon", "-84.29994", "--height", "2",
                  "--pan", "135", "--tilt", "3", "--swing", "0", "--fov", "60", "--size", "64x48"]


def _one_line_error(capsys, code):
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("skyrender: error:"), err
    return err[0]


@pytest.mark.parametrize("extra, words", [
    (["--seed", "-1"], "--seed"),
    (["--skyline-out", "{tmp}/sky.txt"], "--skyline-out"),
    (["--overlay", "{tmp}/overlay.npy"], "--overlay"),
    (["--sky", "purple"], "--sky"),
    (["--clouds", "2"], "--clouds"),
])
def test_render_refuses_bad_values_and_output_names_before_any_work(extra, words, tmp_path, capsys):
    extra = [e.format(tmp=tmp_path) for e in extra]
    out = tmp_path / "view.png"
    code = main(BUILTIN_RENDER + ["--out", str(out)] + extra)
    assert words in _one_line_error(capsys, code)
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_an_explicit_variant_that_cannot_run_is_refused(tmp_path):
    import shutil

    if shutil.which("nvidia-smi"):
        pytest.skip("this machine has an NVIDIA GPU: cuda_ad_rgb may run")
    proc = subprocess.run([sys.executable, "-m", "skyrender.cli"] + BUILTIN_RENDER +
                          ["--out", str(tmp_path / "v.png"), "--variant", "cuda_ad_rgb"],
                          capture_output=True, text=True, timeout=300)
    err = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(err) == 1 and "cuda_ad_rgb" in err[0], proc.stderr


def test_a_truncated_png_gives_one_line(tmp_path, capsys):
    import cv2

    path = tmp_path / "cut.png"
    ok, buf = cv2.imencode(".png", np.random.default_rng(0).integers(0, 255, (60, 80, 3), dtype=np.uint8))
    path.write_bytes(buf.tobytes()[: len(buf) // 2])
    assert "truncated" in _one_line_error(capsys, main(["skyline", str(path)]))


def test_a_corrupt_model_directory_gives_one_line(tmp_path, capsys):
    (tmp_path / "model.json").write_text(json.dumps({"format": "skyrender-model"}))
    (tmp_path / "arrays.npz").write_bytes(b"PK\x03\x04 not a zip")
    img = tmp_path / "p.png"
    import cv2

    cv2.imwrite(str(img), np.zeros((48, 64, 3), np.uint8))
    code = main(["localize", str(img), "--model", str(tmp_path), "--height", "2"])
    _one_line_error(capsys, code)


def test_a_short_fuzz_run_of_malformed_inputs_has_no_failures():
    """``make fuzz`` runs 1,000 cases; here 80 of another seed: mutated DEMs, images and
    model directories and bad flags each end in exit 0/2/3 with one stderr line at most,
    writing nothing but the outputs asked for."""
    from skyrender.diagnostics.fuzz import fuzz

    report = fuzz(n=80, seed=7, limit_s=60.0, progress=False)
    assert report["cases"] == 80
    assert report["failures"] == []


def test_overlay_labels_of_nearby_peaks_do_not_overlap():
    from skyrender.viz import place_labels

    # five peaks a few pixels apart, labels 90 x 10 px: none may overlap, all inside the image
    anchors = [(100 + 6 * i, 80 + (i % 2) * 3) for i in range(5)]
    spots = place_labels(anchors, [(90, 10)] * 5, (120, 320))
    boxes = [(x, y - 10, x + 90, y + 3) for x, y in (s for s in spots if s is not None)]
    assert len(boxes) >= 4
    for i, a in enumerate(boxes):
        assert 0 <= a[0] and a[2] <= 320 and 0 <= a[1] and a[3] <= 120
        for b in boxes[i + 1:]:
            assert a[2] <= b[0] or a[0] >= b[2] or a[3] <= b[1] or a[1] >= b[3]
    assert spots[0] == (104, 72)  # the first (highest) keeps its place beside its peak
    # no room at all: the label is dropped, not drawn over another
    assert place_labels([(5, 5), (6, 6)], [(300, 10)] * 2, (20, 40)) == [None, None]


def test_the_cli_says_what_a_second_opinion_found():
    """``skyrender localize``'s line names a second opinion (the photo preset with the fov given): agreed with an
    answer, agreed but not enough, or where it ended; nothing when none was asked."""
    from skyrender.cli import second_opinion_text

    assert second_opinion_text(None, True) == "" and second_opinion_text({}, False) == ""
    assert second_opinion_text({"apart_m": 341.3}, True) == (
        " (a second search with the fov unknown agreed: its best place 341 m away)")
    assert second_opinion_text({"apart_m": 341.3}, False).endswith("agreed (341 m away), not enough to answer")
    assert second_opinion_text({"apart_m": 56928.0}, False) == "; a second search with the fov unknown ended 56.9 km away"
    assert "ended 1.5 km" in second_opinion_text({"apart_m": 1500.0}, False, agree_m=1000.0)
