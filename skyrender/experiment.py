"""The experiment runner: ``skyrender experiment experiments/NAME.toml``.

Runs localization over datasets x configurations and writes ``results/`` beside the
config (or ``--out``):

- ``results.jsonl``: one JSON line per (dataset, view, configuration): truth, estimate,
  status, confidence, seconds (photo loading, skyline extraction and localization, as a
  user waits once the model is loaded; the dataset's model loading or building is
  ``model_seconds``), per-stage seconds, hypotheses generated / solved / rejected per
  constraint. Finished lines are skipped when the run is repeated (resuming).
- ``tables.md``: per dataset, the paper's table (:func:`skyrender.evaluate.results_table`)
  and the mean per-stage seconds, under a provenance header.
- ``error_cdf.png``, ``seconds.png``, ``stages.png`` and ``worst.png`` (an overlay gallery
  of the worst views: photo, true skyline, the estimate's rendered skyline).

Config format (paths relative to the config file)::

    name = "naval2000"
    [[datasets]]
    name = "synthetic"
    path = "naval2000/datasets/synthetic"   # a frozen dataset (skyrender dataset) ...
    scene = "../scenes/naval2000.toml"     # ... written from this recipe when missing
    n = 50
    seed = 0
    [[datasets]]
    name = "ch1-validation"
    ch1 = "validation"                     # or real photos with known positions (side of the split)
    limit = 10
    [configurations."prior + order"]
    preset = "render"                      # or "photo"; then any LocalizeParams field:
    overrides = { ordered = true }
    prior = "peak-in-view"                 # the truth's most prominent visible model peak, as the paper's prior
    fov = "known"                          # or "unknown"
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field

import numpy as np
import tomllib

from .errors import InputError
from .evaluate import orientation_errors, position_errors, provenance, provenance_header, results_table, summarize
from .progress import progress as progress_bar

PRIORS = ("none", "peak-in-view")


@dataclass(frozen=True)
class Configuration:
    name: str
    preset: str = "render"
    overrides: dict = field(default_factory=dict)
    prior: str = "none"
    fov: str = "known"

    def params(self):
        from .localizer import LocalizeParams

        return LocalizeParams.from_dict(self.overrides, LocalizeParams.preset(self.preset))


@dataclass(frozen=True)
class DatasetRef:
    name: str
    path: str | None = None  # a frozen synthetic dataset
    scene: str | None = None  # its recipe
    n: int = 0
    seed: int = 0
    ch1: str | None = None  # a side of the real-photo split
    limit: int = 0


@dataclass(frozen=True)
class Experiment:
    name: str
    datasets: tuple[DatasetRef, ...]
    configurations: tuple[Configuration, ...]
    out: str
    workers: int = 0
    gallery: int = 6


def load_experiment(path: str, out: str | None = None) -> Experiment:
    """Read and check an experiment config; InputError names what is wrong."""
    try:
        with open(path, "rb") as f:
            spec = tomllib.load(f)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"cannot read experiment {path}: {exc}") from None
    here = os.path.dirname(os.path.abspath(path))

    def rel(p):
        return None if p is None else (p if os.path.isabs(p) else os.path.join(here, p))

    datasets = []
    for i, d in enumerate(spec.get("datasets", [])):
        unknown = set(d) - {"name", "path", "scene", "n", "seed", "ch1", "limit"}
        if unknown:
            raise InputError(f"{path}: dataset {i}: unknown keys {sorted(unknown)}")
        if not (d.get("path") or d.get("ch1")):
            raise InputError(f"{path}: dataset {i} needs 'path' (a frozen dataset) or 'ch1' (a side of the photo split)")
        datasets.append(DatasetRef(str(d.get("name", f"dataset{i}")), rel(d.get("path")), rel(d.get("scene")),
                                   int(d.get("n", 0)), int(d.get("seed", 0)), d.get("ch1"), int(d.get("limit", 0))))
    configurations = []
    for name, c in (spec.get("configurations") or {}).items():
        unknown = set(c) - {"preset", "overrides", "prior", "fov"}
        if unknown:
            raise InputError(f"{path}: configuration {name!r}: unknown keys {sorted(unknown)}")
        conf = Configuration(name, c.get("preset", "render"), dict(c.get("overrides", {})), c.get("prior", "none"),
                             c.get("fov", "known"))
        if conf.prior not in PRIORS or conf.fov not in ("known", "unknown"):
            raise InputError(f"{path}: configuration {name!r}: prior one of {PRIORS}, fov known or unknown")
        conf.params()  # unknown fields fail here, before anything runs
        configurations.append(conf)
    if not datasets or not configurations:
        raise InputError(f"{path}: needs at least one [[datasets]] and one [configurations.NAME]")
    name = str(spec.get("name", os.path.splitext(os.path.basename(path))[0]))
    return Experiment(name, tuple(datasets), tuple(configurations), out or os.path.join(here, name, "results"),
                      int(spec.get("workers", 0)), int(spec.get("gallery", 6)))


# --- frozen synthetic datasets ------------------------------------------------------------
def read_dataset(path: str) -> tuple[dict, list[dict]]:
    """(manifest, view records with ``index`` and file paths) of a frozen dataset."""
    from .datasets.synthetic import FORMAT, view_paths

    try:
        with open(os.path.join(path, "manifest.json")) as f:
            manifest = json.load(f)
        manifest["scene"] = os.path.normpath(os.path.join(path, manifest["scene"]))
    except (OSError, ValueError):
        raise InputError(f"{path} is not a dataset (no readable manifest.json; skyrender dataset writes one)") from None
    if manifest.get("format") != FORMAT:
        raise InputError(f"{path}/manifest.json is not a skyrender dataset")
    jpeg = manifest["realism"]["jpeg_quality"] > 0
    views = []
    for i in range(int(manifest["views"])):
        paths = view_paths(path, i, jpeg)
        try:
            with open(paths["record"]) as f:
                record = json.load(f)
        except (OSError, ValueError):
            raise InputError(f"{path}: view {i} is missing or damaged (re-run skyrender dataset to finish it)") from None
        views.append({**record, "index": i, "paths": paths})
    return manifest, views


def ensure_dataset(ref: DatasetRef, workers: int = 0, progress: bool = True) -> str:
    """The dataset's folder, written from its recipe first when it is not there (or not finished)."""
    if ref.scene:
        from .datasets.synthetic import write_dataset

        if ref.n < 1:
            raise InputError(f"dataset {ref.name!r}: a recipe needs n >= 1")
        write_dataset(ref.scene, ref.n, ref.path, ref.seed, progress=progress, workers=workers)
    return ref.path


def peak_in_view(model, pose, intrinsics, true_skyline: np.ndarray, tol_px: float = 3.0) -> int | None:
    """The paper's prior ("this mountain is in view"): of the model's major peaks that project
    onto the true skyline (within ``tol_px``), the highest; its feature id, or None."""
    from .camera import project

    f = model.features
    uv, front = project(f.xyz, pose, intrinsics)
    uv = np.where(np.isfinite(uv), uv, -1.0)  # points behind the camera
    u = np.floor(uv[:, 0]).astype(int)
    inside = front & (u >= 0) & (u < intrinsics.width) & (uv[:, 1] >= 0) & (uv[:, 1] < intrinsics.height)
    on = np.zeros(len(u), bool)
    on[inside] = np.abs(uv[inside, 1] - true_skyline[u[inside]]) <= tol_px
    on &= f.major
    if not on.any():
        return None
    best = np.flatnonzero(on)[np.argmax(f.xyz[on, 2])]
    return int(f.id[best])


class _Localizer:
    """The model and terrain of one dataset, built once (per process or Dask worker)."""

    def __init__(self, manifest: dict):
        from .dem import load_dem
        from .render import Terrain
        from .scenes import load_scene

        t = time.perf_counter()
        dem = load_dem(manifest["dem"]) if manifest["dem"].startswith("builtin:") else load_scene(manifest["scene"]).dem
        if dem.fingerprint() != manifest["dem_fingerprint"]:
            raise InputError(f"the DEM {manifest['dem']} is not the one the dataset was rendered from")
        block = int(manifest["realism"].get("localize_dem_block", 1))
        self.dem = dem.coarsened(block)  # DEM mismatch: the model knows only the coarser DEM
        self.terrain = Terrain(self.dem)
        self._models = {}
        self.model_for("render")
        self.seconds = time.perf_counter() - t

    def model_for(self, preset: str):
        """The model a preset localizes with (the photo preset's has denser, nearer horizons),
        from the cache or built once."""
        from .model import ModelParams, cached_model

        if preset not in self._models:
            params = ModelParams.for_photos() if preset == "photo" else ModelParams()
            self._models[preset] = cached_model(self.dem, params, terrain=self.terrain)
        return self._models[preset]

    def run(self, view: dict, conf: Configuration) -> dict:
        from .camera import Intrinsics, Pose
        from .features import extract_skyline, load_photo
        from .localizer import localize

        params = conf.params()
        model = self.model_for(conf.preset)
        truth = Pose(*(float(view[k]) for k in ("x", "y", "z", "pan", "tilt", "swing")))
        intrinsics = Intrinsics.from_fov(float(view["fov"]), int(view["width"]), int(view["height"]))
        prior_id = None
        if conf.prior == "peak-in-view":
            prior_id = peak_in_view(model, truth, intrinsics, np.load(view["paths"]["skyline"]))
        t = time.perf_counter()
        image = load_photo(view["paths"]["image"])
        skyline = extract_skyline(image, params.skyline_params())
        result = localize(image, model, float(view["height_above_ground"]),
                          float(view["fov"]) if conf.fov == "known" else None,
                          None if prior_id is None else {"ids": [prior_id]}, terrain=self.terrain, skyline=skyline,
                          params=params)
        seconds = time.perf_counter() - t
        return result_row(truth.array(), result, seconds, prior_id=prior_id)


def result_row(truth: np.ndarray, result, seconds: float, **extra) -> dict:
    """One results.jsonl row of a LocalizationResult against a true pose (6,)."""
    st = result.stats.to_dict()
    row = {"truth": [float(v) for v in truth], "status": result.status, "localized": bool(result.localized),
           "confidence": float(result.confidence), "seconds": seconds, "stage_seconds": st["seconds"],
           "hypotheses": int(result.hypotheses), "generated": int(st["generated"]), "rejected": {
               "visibility": int(st["rejected"].get("interfeature_visibility", 0)),
               "skyline": int(st["rejected"].get("skyline_limit", 0)),
               **{k: int(v) for k, v in st["rejected"].items() if k not in ("interfeature_visibility", "skyline_limit")}},
           "estimate": None, "position_error_m": None, "orientation_error_deg": None, **extra}
    withheld = _withheld_answer(st["refined_poses"]) if not result.localized else None
    if withheld is not None:  # what an abstention withheld: the best refined candidate (analysts look there next)
        row["withheld_estimate"] = withheld
        row["withheld_error_m"] = float(position_errors(np.array(withheld), truth)[0])
    row["best_score"], row["runner_up_score"] = st["best_score"], st["runner_up_score"]
    if result.localized:
        row["estimate"] = [float(v) for v in result.pose]
        row["fov_estimate"] = result.fov
        row["position_error_m"] = float(position_errors(result.pose, truth)[0])
        row["orientation_error_deg"] = float(orientation_errors(result.pose, truth)[0])
    return row


def _withheld_answer(refined_poses: list) -> list[float] | None:
    """The pose (6,) of the best-scored refined candidate ([x, y, z, pan, tilt, swing, f_px, score px]
    rows, :class:`~skyrender.localizer.result.LocalizeStats`), None when none was refined."""
    if not refined_poses:
        return None
    best = min(refined_poses, key=lambda r: r[7])
    return [float(v) for v in best[:6]]


# --- worker tasks (Dask) --------------------------------------------------------------------
_WORKER: dict = {}


def _task(dataset_path: str, view: dict, conf: Configuration) -> dict:
    key = ("localizer", dataset_path)
    if key not in _WORKER:
        manifest, _ = read_dataset(dataset_path)
        _WORKER[key] = _Localizer(manifest)
    return _WORKER[key].run(view, conf)


# --- the run --------------------------------------------------------------------------------
def _done_keys(path: str) -> tuple[set, list[dict]]:
    rows = []
    if os.path.exists(path):
        with open(path) as f:
            for line in f:
                line = line.strip()
                if line:
                    try:
                        rows.append(json.loads(line))
                    except ValueError:
                        continue  # a line cut short by an interruption: that view runs again
    return {(r["dataset"], r["view"], r["configuration"]) for r in rows}, rows


def run_experiment(exp: Experiment, *, workers: int | None = None, scheduler: str | None = None,
                   progress: bool = True, tables_only: bool = False) -> dict:
    """Run every (dataset, view, configuration) not yet in results.jsonl (none with
    ``tables_only``: a partial run's tables), then write the tables and plots from all rows.
    Returns {"rows": [...], "tables": markdown}."""
    workers = exp.workers if workers is None else workers
    created = not os.path.exists(exp.out)
    try:
        os.makedirs(exp.out, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot write results to {exp.out}: {exc.strerror}") from None
    results_path = os.path.join(exp.out, "results.jsonl")
    done, rows = _done_keys(results_path)
    try:
        if not tables_only:
            _run_all(exp, done, rows, results_path, workers, scheduler, progress)
    except BaseException:
        if created and not rows:  # nothing ran: leave no folder behind
            import shutil

            shutil.rmtree(exp.out, ignore_errors=True)
        raise
    tables = write_tables(exp, rows)
    write_plots(exp, rows)
    return {"rows": rows, "tables": tables}


def _run_all(exp: Experiment, done: set, rows: list[dict], results_path: str, workers: int, scheduler: str | None,
             progress: bool) -> None:
    """Every (dataset, view, configuration) not in ``done``, appended to results.jsonl and ``rows``."""
    with open(results_path, "a") as sink:
        def keep(row):
            sink.write(json.dumps(row, sort_keys=True) + "\n")
            sink.flush()
            rows.append(row)

        for ref in exp.datasets:
            if ref.ch1:
                _run_ch1(ref, exp.configurations, done, keep, progress)
                continue
            path = ensure_dataset(ref, workers, progress)
            manifest, views = read_dataset(path)
            todo = [(v, c) for v in views for c in exp.configurations if (ref.name, v["index"], c.name) not in done]
            if not todo:
                continue
            if workers or scheduler:
                _run_on_dask(ref, path, manifest, todo, keep, workers, scheduler, progress)
                continue
            localizer = _Localizer(manifest)
            for view, conf in progress_bar(todo, f"{ref.name}", progress, unit="run"):
                row = localizer.run(view, conf)
                keep({"dataset": ref.name, "view": view["index"], "configuration": conf.name,
                      "model_seconds": localizer.seconds, **row})


def _run_on_dask(ref, path, manifest, todo, keep, workers, scheduler, progress) -> None:
    from distributed import as_completed

    from .scale import dask_client

    local = _Localizer(manifest)  # builds and caches the models once, before the workers load them
    for preset in {conf.preset for _, conf in todo}:
        local.model_for(preset)
    with dask_client(workers=workers, scheduler=scheduler) as client:
        futures = {client.submit(_task, path, view, conf, pure=False): (view, conf) for view, conf in todo}
        for future in progress_bar(as_completed(futures), ref.name, progress, total=len(futures), unit="run"):
            view, conf = futures[future]
            keep({"dataset": ref.name, "view": view["index"], "configuration": conf.name, **future.result()})


def _run_ch1(ref: DatasetRef, configurations, done: set, keep, progress: bool) -> None:
    """Real photos of one side of the split, localized against the SRTM mosaic around their
    place (:func:`skyrender.benchmarks.real_localize.run`), in the runner's row format."""
    from .benchmarks.real_localize import run
    from .datasets.real_photos import items_on_side

    items = [it for it in items_on_side(ref.ch1) if it.key.startswith("ch1/")]
    if ref.limit:
        items = items[:: max(1, len(items) // ref.limit)][: ref.limit]
    for conf in configurations:
        todo = [it for it in items if (ref.name, it.key, conf.name) not in done]
        if not todo:
            continue
        for it, r in zip(todo, run(todo, [conf.fov], progress=progress, params=conf.params())):
            localized = r["status"] == "localized"
            keep({"dataset": ref.name, "view": it.key, "configuration": conf.name, "truth": [it.lat, it.lon],
                  "status": r["status"], "localized": localized, "confidence": r["confidence"],
                  "seconds": r["seconds"], "model_seconds": r["model_seconds"], "stage_seconds": r["stage_seconds"],
                  "position_error_m": r.get("error_m"), "orientation_error_deg": None, "hypotheses": 0})


# --- tables and plots ----------------------------------------------------------------------
def _by(rows: list[dict], dataset: str) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for r in rows:
        if r["dataset"] == dataset:
            out.setdefault(r["configuration"], []).append(r)
    return out


def write_tables(exp: Experiment, rows: list[dict]) -> str:
    """tables.md: provenance, then per dataset the results table and the per-stage seconds."""
    wrong = {ref.name: (1000.0 if ref.ch1 else 100.0) for ref in exp.datasets}
    info = provenance(experiment=exp.name, configurations={c.name: {"preset": c.preset, "overrides": c.overrides,
                                                                   "prior": c.prior, "fov": c.fov}
                                                          for c in exp.configurations})
    parts = [provenance_header(info), f"# {exp.name}", ""]
    for ref in exp.datasets:
        groups = _by(rows, ref.name)
        if not groups:
            continue
        parts += [f"## {ref.name}", "", results_table({k: summarize(v, wrong[ref.name]) for k, v in groups.items()},
                                                       wrong[ref.name]), ""]
        stages = sorted({s for rs in groups.values() for r in rs for s in (r.get("stage_seconds") or {})})
        if stages:
            parts += ["Mean seconds per stage:", "", "| configuration | " + " | ".join(stages) + " |",
                      "|---|" + "---|" * len(stages)]
            for name, rs in groups.items():
                means = [np.mean([(r.get("stage_seconds") or {}).get(s, 0.0) for r in rs]) for s in stages]
                parts.append(f"| {name} | " + " | ".join(f"{m:.2f}" for m in means) + " |")
            parts.append("")
        model_s = [r.get("model_seconds") for rs in groups.values() for r in rs if r.get("model_seconds") is not None]
        if model_s:
            parts += [f"Model loading or building: {max(model_s):.1f} s once per dataset (not in the times above).", ""]
    text = "\n".join(parts)
    with open(os.path.join(exp.out, "tables.md"), "w") as f:
        f.write(text)
    return text


def write_plots(exp: Experiment, rows: list[dict]) -> list[str]:
    """error_cdf.png, seconds.png and stages.png (one panel per dataset), worst.png."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [ref.name for ref in exp.datasets if _by(rows, ref.name)]
    if not names:
        return []
    written = []
    for kind in ("error_cdf", "seconds", "stages"):
        fig, axes = plt.subplots(1, len(names), figsize=(5.5 * len(names), 4), squeeze=False)
        for ax, name in zip(axes[0], names):
            groups = _by(rows, name)
            if kind == "error_cdf":
                for conf, rs in groups.items():
                    err = np.sort([r["position_error_m"] for r in rs if r.get("position_error_m") is not None])
                    if len(err):
                        ax.step(np.maximum(err, 0.1), np.arange(1, len(err) + 1) / len(rs), where="post", label=conf)
                ax.set_xscale("log")
                ax.set_xlabel("position error (m)")
                ax.set_ylabel("share of views within")
                ax.set_ylim(0, 1)
            elif kind == "seconds":
                ax.boxplot([[r["seconds"] for r in rs] for rs in groups.values()], tick_labels=list(groups))
                ax.set_ylabel("seconds per view")
                ax.tick_params(axis="x", rotation=20)
            else:
                stages = sorted({s for rs in groups.values() for r in rs for s in (r.get("stage_seconds") or {})})
                bottom = np.zeros(len(groups))
                for s in stages:
                    means = np.array([np.mean([(r.get("stage_seconds") or {}).get(s, 0.0) for r in rs])
                                      for rs in groups.values()])
                    ax.bar(list(groups), means, bottom=bottom, label=s)
                    bottom += means
                ax.set_ylabel("mean seconds")
                ax.tick_params(axis="x", rotation=20)
            ax.set_title(name)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7)
        fig.tight_layout()
        path = os.path.join(exp.out, f"{kind}.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        written.append(path)
    gallery = worst_gallery(exp, rows)
    return written + ([gallery] if gallery else [])


def worst_gallery(exp: Experiment, rows: list[dict]) -> str | None:
    """worst.png: the ``exp.gallery`` worst views of the synthetic datasets (abstentions first,
    then the largest errors): the photo with its true skyline (green) and, where it answered,
    the skyline rendered at the estimate (red)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .camera import Intrinsics, Pose
    from .features import load_photo
    from .render import render_skylines

    synthetic = {ref.name: ref for ref in exp.datasets if not ref.ch1}
    cand = [r for r in rows if r["dataset"] in synthetic]
    if not cand or exp.gallery <= 0:
        return None
    cand.sort(key=lambda r: (r["localized"], -(r.get("position_error_m") or 0.0)))
    cand = cand[: exp.gallery]
    fig, axes = plt.subplots(1, len(cand), figsize=(4 * len(cand), 3.4), squeeze=False)
    localizers: dict[str, object] = {}
    for ax, r in zip(axes[0], cand):
        manifest, views = read_dataset(synthetic[r["dataset"]].path)
        view = views[r["view"]]
        image = load_photo(view["paths"]["image"])
        ax.imshow(image)
        u = np.arange(image.shape[1]) + 0.5
        ax.plot(u, np.load(view["paths"]["skyline"]), color="lime", lw=1)
        if r["localized"]:
            if r["dataset"] not in localizers:
                localizers[r["dataset"]] = _Localizer(manifest)
            intr = Intrinsics.from_fov(r.get("fov_estimate") or view["fov"], int(view["width"]), int(view["height"]))
            ax.plot(u, render_skylines(localizers[r["dataset"]].terrain, Pose(*r["estimate"]), intr), color="red", lw=1)
            title = f"{r['position_error_m']:.0f} m, {r['orientation_error_deg']:.2f} deg"
        else:
            title = "abstained"
        ax.set_title(f"{r['dataset']} #{r['view']} {r['configuration']}\n{title}", fontsize=8)
        ax.axis("off")
    fig.tight_layout()
    path = os.path.join(exp.out, "worst.png")
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
