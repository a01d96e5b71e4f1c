"""Datasets and experiments: frozen synthetic datasets, the experiment runner, evaluation,
parameter dicts, Dask. A small synthetic scene (8 x 8 km) keeps them quick."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from skyrender.cli import main as cli_main


@pytest.fixture(scope="module")
def tiny_scene(tmp_path_factory) -> Path:
    """A scene file on a 160 x 160-cell (50 m) fractal DEM with a [dataset] recipe of
    320 x 240 views, skies and lens distortion drawn per view."""
    from skyrender.dem.synthetic import fractal_terrain

    root = tmp_path_factory.mktemp("scene")
    dem = fractal_terrain(size=160, cell_size=50.0, seed=4, mountain_height=900.0)
    np.savez(root / "dem.npz", elevation=dem.elevation, cell_size=50.0)
    (root / "tiny.toml").write_text(
        'dem = "dem.npz"\n'
        "[dataset.sampling]\nsize = [320, 240]\nfov_deg = [40.0, 60.0]\nfar_m = 500.0\nmin_relief = 0.03\n"
        '[dataset.realism]\nskies = ["clear", "hazy", "sunset"]\nk1 = [-0.04, 0.04]\nnoise = [0.0, 0.01]\n')
    return root / "tiny.toml"


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def tiny_dataset(tiny_scene, tmp_path_factory) -> Path:
    from skyrender.datasets.synthetic import write_dataset

    out = tmp_path_factory.mktemp("data") / "tiny"
    write_dataset(str(tiny_scene), 3, str(out), seed=5, progress=False)
    return out


# --- parameters ---------------------------------------------------------------------------
def test_localize_params_round_trip_through_dicts_and_name_unknown_fields():
    from skyrender.errors import InputError
    from skyrender.localizer import LocalizeParams

    photo = LocalizeParams.preset("photo")
    assert LocalizeParams.from_dict(json.loads(json.dumps(photo.to_dict()))) == photo
    changed = LocalizeParams.from_dict({"final_refinements": 2, "horizon": {"tilts": [0.0, 15.0]}}, photo)
    assert changed.final_refinements == 2 and changed.horizon.tilts == (0.0, 15.0)
    assert changed.min_confidence == photo.min_confidence and changed.horizon.terms == photo.horizon.terms
    # the tuning constants of the solver, the order and the refinement are fields too
    tuned = LocalizeParams.from_dict({"gn_iterations": 2, "prior_boost": 10.0,
                                      "refine": {"search_levels": [[40, 40, 5, 5], [3, 3, 5, 5]], "sweep_stride": 4}})
    assert tuned.gn_iterations == 2 and tuned.prior_boost == 10.0
    assert tuned.refine.search_levels == ((40, 40, 5, 5), (3, 3, 5, 5)) and tuned.refine.sweep_stride == 4
    assert tuned.refine.sweep_max_poses == LocalizeParams().refine.sweep_max_poses
    with pytest.raises(InputError, match="unknown parameter 'horizon.tilt'"):
        LocalizeParams.from_dict({"horizon": {"tilt": [0.0]}})
    with pytest.raises(InputError, match="takes a number"):
        LocalizeParams.from_dict({"chunk": "many"})
    with pytest.raises(InputError, match="unknown preset"):
        LocalizeParams.preset("fast")


def test_block_mean_dem_is_a_coarser_copy_of_the_same_terrain():
    from skyrender.dem.synthetic import fractal_terrain

    dem = fractal_terrain(size=90, cell_size=30.0, seed=1)
    coarse = dem.coarsened(3)
    assert coarse.shape == (30, 30) and coarse.cell_size == (90.0, 90.0)
    assert coarse.elevation[4, 7] == pytest.approx(dem.elevation[12:15, 21:24].mean())
    # the same ground where the block's centre is
    x, y = coarse.x_centres[7], coarse.y_centres[4]
    assert float(coarse.ground(x, y)) == pytest.approx(dem.elevation[12:15, 21:24].mean())
    assert dem.x_centres[22] == pytest.approx(x) and dem.y_centres[13] == pytest.approx(y)


# --- evaluation ------------------------------------------------------------------------------
def test_pose_errors_recall_and_summary():
    from skyrender.evaluate import orientation_errors, position_errors, recall, results_table, summarize

    truth = np.array([[0.0, 0.0, 5.0, 359.0, 1.0, 0.0], [10.0, 10.0, 0.0, 10.0, 0.0, 0.0]])
    est = np.array([[3.0, 4.0, 90.0, 1.0, 1.5, 0.0], [10.0, 10.0, 0.0, 10.0, 0.0, -0.25]])
    assert position_errors(est, truth).tolist() == [5.0, 0.0]  # horizontal only
    assert orientation_errors(est, truth).tolist() == pytest.approx([2.0, 0.25])  # wrapped
    assert recall(np.array([5.0, np.nan, 500.0, 20.0]), (10.0, 100.0)) == {10.0: 0.25, 100.0: 0.5}
    rows = [{"localized": True, "position_error_m": 5.0, "orientation_error_deg": 0.1, "seconds": 2.0, "hypotheses": 10,
             "rejected": {"visibility": 3, "skyline": 1}},
            {"localized": True, "position_error_m": 400.0, "orientation_error_deg": 3.0, "seconds": 4.0, "hypotheses": 30},
            {"localized": False, "seconds": 6.0, "hypotheses": 20}]
    s = summarize(rows, wrong_m=100.0)
    assert (s.views, s.localized, s.right, s.wrong, s.abstained) == (3, 2, 1, 1, 1)
    assert s.position_m["max"] == 5.0 and s.seconds["mean"] == 4.0 and s.hypotheses_per_s == 5.0
    assert s.rejected_visibility == 3 and s.recall[1000.0] == pytest.approx(2 / 3)
    table = results_table({"cfg": s}, wrong_m=100.0)
    assert "| cfg | 3 | 5.0/5.0/5.0 | 0.100 | 2 | 1 | 1 | 2.0/4.0/6.0 | 5 | 3 | 1 | 33 % | 33 % | 67 % |" in table


def test_a_result_row_of_an_abstention_keeps_the_withheld_answer_and_its_error():
    """An abstention's row names the best-scored refined candidate (the place an analyst checks next) and its
    error, so an experiment can count what was withheld; an answer's row has no such fields."""
    from skyrender.experiment import result_row
    from skyrender.localizer.result import LocalizationResult, LocalizeStats

    stats = LocalizeStats(best_score=1.5, runner_up_score=1.6,
                          refined_poses=[[300.0, 400.0, 9.0, 10.0, 1.0, 0.0, 800.0, 2.5],
                                         [30.0, 40.0, 9.0, 12.0, 2.0, 1.0, 800.0, 1.5]])
    truth = np.array([0.0, 0.0, 9.0, 10.0, 1.0, 0.0])
    row = result_row(truth, LocalizationResult("abstained", None, None, 0.2, 3.0, 0, stats), 3.0)
    assert row["estimate"] is None and row["withheld_estimate"] == [30.0, 40.0, 9.0, 12.0, 2.0, 1.0]
    assert row["withheld_error_m"] == 50.0 and (row["best_score"], row["runner_up_score"]) == (1.5, 1.6)
    answered = result_row(truth, LocalizationResult("localized", np.array([30.0, 40.0, 9.0, 12.0, 2.0, 1.0]), 40.0,
                                                    0.99, 3.0, 0, stats), 3.0)
    assert answered["position_error_m"] == 50.0 and "withheld_error_m" not in answered
    assert "withheld_error_m" not in result_row(truth, LocalizationResult("abstained", None, None, 0.0, 3.0, 0,
                                                                           LocalizeStats()), 3.0)


# --- datasets --------------------------------------------------------------------------------
def test_a_dataset_holds_what_the_renderer_sees(tiny_dataset, tiny_scene):
    import cv2

    from skyrender.camera import Intrinsics, Pose
    from skyrender.datasets.synthetic import distort
    from skyrender.render import Terrain, render_skylines
    from skyrender.scenes import load_scene

    manifest = json.loads((tiny_dataset / "manifest.json").read_text())
    assert manifest["views"] == 3 and manifest["seed"] == 5 and manifest["format"] == "skyrender-dataset"
    scene = load_scene(tiny_scene)
    assert manifest["dem_fingerprint"] == scene.dem.fingerprint() and manifest["commit"]
    terrain = Terrain(scene.dem)
    skies = set()
    for i in range(3):
        record = json.loads((tiny_dataset / "views" / f"{i:06d}.json").read_text())
        skies.add(record["look"]["sky"])
        pose = Pose(*(record[k] for k in ("x", "y", "z", "pan", "tilt", "swing")))
        intr = Intrinsics.from_fov(record["fov"], record["width"], record["height"])
        assert record["z"] == pytest.approx(float(scene.dem.ground(pose.x, pose.y)) + record["height_above_ground"])
        assert 40.0 <= record["fov"] <= 60.0 and abs(record["swing"]) <= 15.0 and abs(record["k1"]) <= 0.04
        truth = np.load(tiny_dataset / "views" / f"{i:06d}_skyline.npy")
        pinhole = render_skylines(terrain, pose, intr)
        # the stored truth is the renderer's skyline seen through the view's lens
        expected = distort(np.zeros((intr.height, intr.width, 3), np.uint8), pinhole, pinhole, intr,
                           record["k1"], record["k2"])[1]
        assert np.nanmax(np.abs(truth - expected)) < 0.05
        mask = cv2.imread(str(tiny_dataset / "views" / f"{i:06d}_mask.png"), cv2.IMREAD_GRAYSCALE)
        first_terrain = np.argmax(mask > 127, axis=0)
        assert np.median(np.abs(first_terrain + 0.5 - truth)) <= 1.0  # no occluders: the mask's edge is the skyline
        inside = np.isfinite(truth) & (truth > 0) & (truth < intr.height)
        assert inside.mean() >= 0.95
    assert len(skies) >= 1


def test_lens_distortion_moves_the_photo_and_its_truth_alike():
    from skyrender.camera import Intrinsics
    from skyrender.datasets.synthetic import boundary_coverage, distort

    intr = Intrinsics.from_fov(60.0, 200, 150)
    u = np.arange(200) + 0.5
    skyline = 30.0 + 15.0 * np.sin(u / 30.0)
    image = (np.repeat(boundary_coverage(skyline, 150)[..., None], 3, axis=2) * 255).astype(np.uint8)
    warped, line, _ = distort(image, skyline, skyline, intr, 0.08, 0.01)
    edge = (255 - warped[..., 0].astype(float)).sum(axis=0) / 255.0  # the sky's share of each column
    assert np.max(np.abs(edge - line)[5:-5]) < 0.3
    assert np.max(np.abs(line - skyline)) > 2.0  # barrel distortion moved it
    same = distort(image, skyline, skyline, intr, 0.0, 0.0)
    assert same[0] is image and same[1] is skyline


def test_a_dataset_is_byte_identical_for_a_seed_and_resumes(tiny_dataset, tiny_scene, tmp_path):
    from skyrender.datasets.synthetic import write_dataset

    again = tmp_path / "again"
    write_dataset(str(tiny_scene), 3, str(again), seed=5, progress=False)
    assert _files(again) == _files(tiny_dataset)
    # resuming: a lost view is rendered again, the others are left as they are
    os.remove(again / "views" / "000001.json")
    kept = (again / "views" / "000002.png").stat().st_mtime_ns
    write_dataset(str(tiny_scene), 3, str(again), seed=5, progress=False)
    assert _files(again) == _files(tiny_dataset)
    assert (again / "views" / "000002.png").stat().st_mtime_ns == kept
    other = tmp_path / "other"
    write_dataset(str(tiny_scene), 1, str(other), seed=6, progress=False)
    assert (other / "views" / "000000.png").read_bytes() != (tiny_dataset / "views" / "000000.png").read_bytes()


def test_dataset_command_refuses_bad_input_in_one_line(tiny_scene, tmp_path, capsys):
    assert cli_main(["dataset", str(tiny_scene), "--n", "0", "--out", str(tmp_path / "d")]) == 2
    assert "--n must be >= 1" in capsys.readouterr().err
    scene = tmp_path / "bad.toml"
    scene.write_text(tiny_scene.read_text().replace("fov_deg = [40.0, 60.0]", "fov = 50"))
    (tmp_path / "dem.npz").write_bytes((tiny_scene.parent / "dem.npz").read_bytes())
    assert cli_main(["dataset", str(scene), "--n", "1", "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err.strip()
    assert "unknown parameter 'dataset.sampling.fov'" in err and len(err.splitlines()) == 1


# --- experiments -----------------------------------------------------------------------------
EXPERIMENT = """
name = "tiny"
gallery = 2
[[datasets]]
name = "fractal"
path = "{dataset}"
[configurations."prior + order"]
prior = "peak-in-view"
overrides = {{ max_hypotheses = 100000 }}
[configurations."no prior"]
overrides = {{ max_hypotheses = 100000, ordered = false }}
"""


def _stable(rows: list[dict]) -> list[dict]:
    """Result rows without their timings, sorted."""
    drop = {"seconds", "stage_seconds", "model_seconds"}
    return sorted(({k: v for k, v in r.items() if k not in drop} for r in rows),
                  key=lambda r: (r["dataset"], r["view"], r["configuration"]))


@pytest.fixture(scope="module")
def tiny_experiment(tiny_dataset, tmp_path_factory):
    from skyrender.experiment import load_experiment, run_experiment

    root = tmp_path_factory.mktemp("exp")
    config = root / "tiny.toml"
    config.write_text(EXPERIMENT.format(dataset=tiny_dataset))
    exp = load_experiment(str(config))
    return exp, run_experiment(exp, progress=False)


def test_an_experiment_writes_results_tables_and_plots(tiny_experiment):
    exp, result = tiny_experiment
    rows = result["rows"]
    assert exp.out.endswith(os.path.join("tiny", "results"))
    assert len(rows) == 6 and {r["configuration"] for r in rows} == {"prior + order", "no prior"}
    for r in rows:
        assert r["localized"] == (r["estimate"] is not None) and r["seconds"] > 0 and r["stage_seconds"]
        if r["localized"]:
            assert r["position_error_m"] == pytest.approx(np.hypot(r["estimate"][0] - r["truth"][0],
                                                                   r["estimate"][1] - r["truth"][1]))
    tables = (Path(exp.out) / "tables.md").read_text()
    assert "commit:" in tables and "variant:" in tables and "cpus:" in tables
    for name in ("prior + order", "no prior"):
        line = next(x for x in tables.splitlines() if x.startswith(f"| {name} | 3 |"))
        cells = [c.strip() for c in line.strip("|").split("|")]
        group = [r for r in rows if r["configuration"] == name]
        assert int(cells[4]) == sum(r["localized"] for r in group) and int(cells[5]) == 3 - int(cells[4])
    for plot in ("error_cdf.png", "seconds.png", "stages.png", "worst.png"):
        assert (Path(exp.out) / plot).stat().st_size > 1000
    assert len((Path(exp.out) / "results.jsonl").read_text().splitlines()) == 6


def test_an_experiment_resumes_and_dask_gives_the_local_results(tiny_experiment, tmp_path):
    from dataclasses import replace

    from skyrender.experiment import run_experiment

    exp, result = tiny_experiment
    results = Path(exp.out) / "results.jsonl"
    before = results.read_text()
    assert _stable(run_experiment(exp, progress=False)["rows"]) == _stable(result["rows"])
    assert results.read_text() == before  # nothing ran again
    partial = replace(exp, out=str(tmp_path / "partial"))
    os.makedirs(partial.out)
    (Path(partial.out) / "results.jsonl").write_text("".join(before.splitlines(True)[:2]))
    assert len(run_experiment(partial, progress=False, tables_only=True)["rows"]) == 2  # tables of 2 lines, nothing run
    on_dask = run_experiment(replace(exp, out=str(tmp_path / "dask")), workers=2, progress=False)
    assert _stable(on_dask["rows"]) == _stable(result["rows"])


def test_experiment_command_names_a_bad_config(tmp_path, capsys):
    config = tmp_path / "bad.toml"
    config.write_text('[[datasets]]\npath = "x"\n[configurations.a]\noverrides = { chunks = 3 }\n')
    assert cli_main(["experiment", str(config)]) == 2
    assert "unknown parameter 'chunks'" in capsys.readouterr().err


def test_every_scene_file_reads_and_names_an_existing_dem():
    """scenes/*.toml: TOML with a DEM (built in, or a file that exists where ../shared/data is)
    and a valid [dataset] recipe; the built-in ones load."""
    import tomllib

    from skyrender.datasets.synthetic import dataset_spec
    from skyrender.dem.io import BUILTIN_DEMS
    from skyrender.scenes import load_scene

    scenes = sorted((Path(__file__).resolve().parents[1] / "scenes").glob("*.toml"))
    assert len(scenes) >= 20
    shared = Path(__file__).resolve().parents[2] / "shared" / "data" / "dem"
    for path in scenes:
        spec = tomllib.loads(path.read_text())
        dataset_spec(spec.get("dataset"))
        if spec["dem"] in BUILTIN_DEMS:
            assert load_scene(path).dem.shape[0] > 100
        else:
            assert spec["dem"].startswith("../../shared/data/dem/")
            if shared.exists():
                assert (path.parent / spec["dem"]).resolve().exists(), path.name


def test_dataset_views_never_stand_on_or_look_at_invented_terrain(tmp_path):
    """A DEM with no data over half its area (a missing tile; the Glarus DEM has none outside the canton) is
    filled on load, and the fill is made up: the sampler draws again where the camera would stand on it or more
    than 5 % of the skyline's columns would lie on it. Without the mask, cameras stand there (on the real Glarus
    DEM: 19 of 40 views, 22 of 40 with over 5 % of the skyline invented)."""
    import dataclasses

    from skyrender.datasets.synthetic import MAX_INVENTED_SKYLINE_SHARE, Sampling, invented_skyline_share, sample_view
    from skyrender.dem import load_dem
    from skyrender.dem.synthetic import fractal_terrain
    from skyrender.render import Terrain, render_skylines

    z = fractal_terrain(size=160, cell_size=50.0, seed=4, mountain_height=900.0).elevation.copy()
    z[:, 80:] = np.nan
    np.save(tmp_path / "half.npy", z)
    dem = load_dem(tmp_path / "half.npy", cell_size=50.0)
    assert dem.invented is not None and 0.4 < dem.invented.mean() < 0.5
    sampling = Sampling(size=(320, 240), fov_deg=(40.0, 60.0), far_m=500.0, min_relief=0.03)
    on_invented = {}
    for label, d in (("masked", dem), ("unmasked", dataclasses.replace(dem, invented=None))):
        terrain = Terrain(d)
        poses = [sample_view(terrain, i, 3, sampling) for i in range(8)]
        on_invented[label] = sum(bool(dem.is_invented(p.x, p.y)) for p, *_ in poses)
        if label == "masked":
            for pose, intrinsics, _, skyline in poses:
                sky, distance = render_skylines(terrain, pose, intrinsics, with_distance=True)
                assert invented_skyline_share(dem, pose, intrinsics, sky, distance) <= MAX_INVENTED_SKYLINE_SHARE
    assert on_invented["masked"] == 0 and on_invented["unmasked"] >= 1


def test_a_figure_s_provenance_names_the_libraries_that_move_it():
    import scipy

    from skyrender.evaluate import provenance, versions_line

    info = provenance(seed=3)
    assert info["seed"] == 3 and info["cpus"] == os.cpu_count()
    assert info["versions"]["numpy"] == np.__version__ and info["versions"]["scipy"] == scipy.__version__
    line = versions_line(info["versions"])
    assert f"numpy {np.__version__}" in line and "python " in line
    assert versions_line(None) == "versions not recorded"
