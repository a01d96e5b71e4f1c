"""Fuzz the command line with malformed inputs: every one must end in exit 0, 2 or 3
with at most one line on stderr (a command that ended well: its own warnings, a line each),
within a time limit, writing nothing but the outputs asked for.

``python -m skyrender.diagnostics.fuzz [--n 1000] [--seed 0] [--limit-s 20]`` (``make fuzz``)

Inputs (seeded): DEM files of each format (.hgt, GeoTIFF, .asc, .npy, .npz) truncated,
with bytes flipped, all-NaN, all-void, one row, huge or infinite values; images (PNG,
JPEG) truncated or corrupt, CMYK, 16-bit, gray with alpha, 1 x 1 and 100000 x 2;
model directories corrupt, truncated or foreign; skyline files and masks for ``localize --skyline /
--sky-mask / --terrain-mask`` of the wrong length, size or values, or damaged; scene files for ``dataset`` and configs
for ``experiment`` with bad tables, values or bytes; and out-of-range or malformed flags.
Each case runs in this process through :func:`skyrender.cli.main` with file
descriptor 2 redirected, so a native decoder's own stderr line counts too. Reported:
cases tried, failures (with the case and what went wrong), seconds.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import shutil
import tempfile
import time
from dataclasses import dataclass

import numpy as np

OK_CODES = (0, 2, 3)


@dataclass
class Case:
    name: str
    argv: list[str]
    outputs: tuple[str, ...] = ()  # files the command may write (relative to the work dir)


@dataclass
class Outcome:
    case: Case
    code: int | None
    stderr: str
    seconds: float
    extra_files: list[str]

    def failure(self, limit_s: float) -> str | None:
        """Why this outcome breaks the rules, or None."""
        lines = [ln for ln in self.stderr.splitlines() if ln.strip()]
        if self.code not in OK_CODES:
            return f"exit {self.code}: {lines[-1] if lines else ''}"
        # one line, or (a command that ended well) only the command's own warnings, a line each
        warnings_only = self.code != 2 and all(ln.startswith("skyrender: warning:") for ln in lines)
        if len(lines) > 1 and not warnings_only:
            return f"{len(lines)} stderr lines: {' | '.join(lines[:3])}"
        if self.seconds > limit_s:
            return f"took {self.seconds:.1f} s"
        if self.extra_files:
            return f"wrote {self.extra_files}"
        return None


# --- inputs -------------------------------------------------------------------------------

def _small_dem(rng: np.random.Generator, n: int = 41) -> np.ndarray:
    """A small smooth terrain grid (m), n x n."""
    y, x = np.mgrid[0:n, 0:n] / n
    z = 800 + 400 * np.sin(3 * x + rng.uniform(0, 3)) * np.cos(2 * y) + rng.normal(0, 5, (n, n))
    return z.astype(np.float32)


def _write_geotiff(path: str, z: np.ndarray) -> None:
    import rasterio
    from affine import Affine

    with rasterio.open(path, "w", driver="GTiff", height=z.shape[0], width=z.shape[1], count=1, dtype=z.dtype.name,
                       crs="EPSG:32611", transform=Affine(30.0, 0, 400000.0, 0, -30.0, 3800000.0)) as ds:
        ds.write(z, 1)


def _write_asc(path: str, z: np.ndarray) -> None:
    rows, cols = z.shape
    head = f"ncols {cols}\nnrows {rows}\nxllcorner 0\nyllcorner 0\ncellsize 30\nNODATA_value -9999\n"
    with open(path, "w") as f:
        f.write(head + "\n".join(" ".join(f"{v:.1f}" for v in row) for row in z))


def _dem_grids(rng: np.random.Generator) -> dict[str, np.ndarray]:
    base = _small_dem(rng)
    return {"plain": base, "all_nan": np.full_like(base, np.nan), "all_void": np.full_like(base, -32768.0),
            "one_row": base[:1], "one_cell": base[:1, :1], "huge": base * 1e30, "inf": np.where(base > 900, np.inf, base),
            "negative": -base, "flat": np.zeros_like(base)}


def _mutate_bytes(data: bytes, rng: np.random.Generator) -> bytes:
    """Truncate, flip a few bytes, or splice in garbage, at random."""
    kind = rng.integers(3)
    if kind == 0 or len(data) < 8:
        return data[: int(rng.integers(0, max(len(data), 1)))]
    buf = bytearray(data)
    if kind == 1:
        for i in rng.integers(0, len(buf), size=int(rng.integers(1, 16))):
            buf[i] ^= int(rng.integers(1, 256))
        return bytes(buf)
    at = int(rng.integers(0, len(buf)))
    return bytes(buf[:at]) + rng.bytes(int(rng.integers(1, 64))) + bytes(buf[at:])


def _with_mutants(files: list[str], valid: list[str], work: str, rng: np.random.Generator, n: int) -> list[str]:
    """``files`` topped up to ``n`` with byte mutations of the ``valid`` ones, in turn."""
    files = list(files)
    i = 0
    while len(files) < n:
        src = valid[i % len(valid)]
        with open(src, "rb") as f:
            data = f.read()
        path = os.path.join(work, f"mut{i}_{os.path.basename(src)}")
        with open(path, "wb") as f:
            f.write(_mutate_bytes(data, rng))
        files.append(path)
        i += 1
    return files[:n]


def _dem_files(work: str, rng: np.random.Generator, n: int) -> list[str]:
    """n DEM files: each grid in each format, then byte mutations of the valid ones."""
    files, valid = [], []
    for name, z in _dem_grids(rng).items():
        for ext in (".tif", ".asc", ".npy", ".npz"):
            path = os.path.join(work, f"dem_{name}{ext}")
            if ext == ".tif":
                _write_geotiff(path, z)
            elif ext == ".asc":
                _write_asc(path, z)
            elif ext == ".npy":
                np.save(path, z)
            else:
                np.savez(path, z=z)
            files.append(path)
            if name == "plain":
                valid.append(path)
    hgt = os.path.join(work, "N46E007.hgt")  # a real-size SRTM3 tile, flat with a bump
    tile = np.full((1201, 1201), 500, ">i2")
    tile[500:700, 500:700] = 1500
    tile.tofile(hgt)
    valid.append(hgt)
    files.append(hgt)
    return _with_mutants(files, valid, work, rng, n)


def _dem_folders(work: str, rng: np.random.Generator, dems: list[str]) -> list[tuple[str, str | None]]:
    """(folder, --dem-bounds or None) cases of DEM directories: every kind of DEM file together (a UTM GeoTIFF, a
    grid without a CRS, numpy arrays, an SRTM tile, byte mutants of them), and the valid SRTM tile beside others,
    with windows on it, beside it and nowhere."""
    cases = []
    for name, picked in (("mixed", [d for d in dems if rng.random() < 0.3]),
                         ("tile", [d for d in dems if os.path.basename(d) in ("N46E007.hgt", "dem_plain.tif",
                                                                              "dem_plain.asc")])):
        folder = os.path.join(work, f"folder_{name}")
        os.makedirs(folder)
        for d in picked:
            shutil.copy(d, folder)
        cases += [(folder, None), (folder, "7.2,46.2,7.8,46.8"), (folder, "6.5,46.5,7.5,47.5"), (folder, "100,10,101,11")]
    return cases


def _image_files(work: str, rng: np.random.Generator, n: int) -> list[str]:
    """n image files: odd shapes and kinds, then byte mutations of PNG and JPEG photos."""
    import cv2
    from PIL import Image

    def photo(h, w):
        img = np.zeros((h, w, 3), np.uint8)
        img[: h // 2] = (200, 170, 120)  # sky (BGR)
        img[h // 2:] = (40, 90, 60)
        return img

    files = []
    specials = {"tiny.png": np.zeros((1, 1, 3), np.uint8), "long.png": photo(2, 100000), "tall.png": photo(100000, 2),
                "gray.png": photo(60, 80)[..., 0], "rgba.png": np.dstack([photo(60, 80), np.full((60, 80), 128, np.uint8)]),
                "deep.png": (photo(60, 80).astype(np.uint16) * 257)}
    for name, img in specials.items():
        path = os.path.join(work, name)
        cv2.imwrite(path, img)
        files.append(path)
    cmyk = os.path.join(work, "cmyk.jpg")
    Image.fromarray(photo(60, 80)[..., ::-1]).convert("CMYK").save(cmyk)
    files.append(cmyk)
    empty = os.path.join(work, "empty.png")
    open(empty, "wb").close()
    files.append(empty)
    valid = []
    for ext in (".png", ".jpg"):
        path = os.path.join(work, f"photo{ext}")
        cv2.imwrite(path, photo(96, 128))
        valid.append(path)
    return _with_mutants(files, valid, work, rng, n)


def _skyline_files(work: str, rng: np.random.Generator, n: int, width: int = 128, height: int = 96) -> list[str]:
    """n skyline files for ``localize --skyline`` on a ``width`` x ``height`` photo: wrong lengths and values, odd
    JSON, then byte mutations of valid ``.npy`` and ``.json`` ones."""
    from ..io import save_skyline

    line = np.linspace(0.3, 0.6, width) * height
    specials = {"short.json": line[:-1], "long.npy": np.r_[line, 10.0], "nan.json": np.full(width, np.nan),
                "inf.npy": np.r_[line[:-1], np.inf], "negative.json": -line, "below.npy": line + height,
                "matrix.npy": np.stack([line, line])}
    files = []
    for name, values in specials.items():
        path = os.path.join(work, name)
        save_skyline(path, values)
        files.append(path)
    for name, text in (("words.json", '["a", "b"]'), ("object.json", '{"width": 2}'), ("nested.json", "[[1, 2]]"),
                       ("broken.json", "[1, 2")):
        path = os.path.join(work, name)
        with open(path, "w") as f:
            f.write(text)
        files.append(path)
    valid = []
    for ext in (".npy", ".json"):
        path = os.path.join(work, f"sky{ext}")
        save_skyline(path, line)
        valid.append(path)
    return _with_mutants(files, valid, work, rng, n)


def _model_dirs(work: str, rng: np.random.Generator, valid_model: str, n: int) -> list[str]:
    """n model directories: foreign and corrupt model.json, missing or mutated arrays."""
    dirs = []
    with open(os.path.join(valid_model, "model.json")) as f:
        meta = json.load(f)
    with open(os.path.join(valid_model, "arrays.npz"), "rb") as f:
        arrays = f.read()
    for i in range(n):
        d = os.path.join(work, f"model{i}")
        os.makedirs(d)
        kind = i % 6
        m = json.loads(json.dumps(meta))
        if kind == 0:
            m = {"format": "something-else"}
        elif kind == 1:
            m["format_version"] = 999
        elif kind == 2:
            del m[list(m)[int(rng.integers(len(m)))]]
        elif kind == 3:
            m["params"] = {"peaks": "x"}
        text = json.dumps(m) if kind != 4 else json.dumps(m)[: int(rng.integers(1, 40))]
        with open(os.path.join(d, "model.json"), "w") as f:
            f.write(text)
        if kind != 5 or i % 12 == 5:
            with open(os.path.join(d, "arrays.npz"), "wb") as f:
                f.write(_mutate_bytes(arrays, rng) if kind == 5 else arrays)
        dirs.append(d)
    return dirs


def _bad_flags(rng: np.random.Generator, dem: str, image: str, model: str) -> list[Case]:
    """Out-of-range and malformed flags on every command."""
    render = ["render", "--dem", dem, "--x", "600", "--y", "600", "--height", "2", "--pan", "0", "--tilt", "0",
              "--swing", "0", "--fov", "50", "--size", "32x24", "--out", "r.png"]
    bad_values = ["nan", "inf", "-inf", "-1", "0", "1e300", "abc", "", "1,2", "--"]
    cases = []
    for opt in ("--x", "--y", "--height", "--pan", "--tilt", "--swing", "--fov", "--size", "--seed"):
        for v in bad_values:
            argv = list(render)
            if opt in argv:
                argv[argv.index(opt) + 1] = v
            else:
                argv += [opt, v]
            cases.append(Case(f"render {opt}={v!r}", argv, ("r.png",)))
    for v in bad_values + ["-0.5", "200"]:
        cases.append(Case(f"localize --fov={v!r}", ["localize", image, "--model", model, "--height", "2", "--fov", v]))
        cases.append(Case(f"localize --height={v!r}", ["localize", image, "--model", model, "--height", v]))
        cases.append(Case(f"localize --prior-near={v!r}", ["localize", image, "--model", model, "--height", "2",
                                                          "--prior-near", v]))
        cases.append(Case(f"localize --candidates={v!r}", ["localize", image, "--model", model, "--height", "2",
                                                          "--candidates", v]))
        cases.append(Case(f"model --k={v!r}", ["model", dem, "--out", "m", "--k", v], ("m",)))
        cases.append(Case(f"model --spacing={v!r}", ["model", dem, "--out", "m", "--spacing", v], ("m",)))
    for out in ("x.txt", "nodir/x.png", "", "."):
        cases.append(Case(f"render --out={out!r}", render[:-1] + [out]))
        cases.append(Case(f"skyline --out={out!r}", ["skyline", image, "--out", out]))
    cases.append(Case("unknown command", ["frobnicate"]))
    cases.append(Case("unknown option", ["render", "--bogus"]))
    rng.shuffle(cases)
    return cases


SCENE_BODIES = (
    '[dataset.sampling]\nsize = [32, 24]\nmax_draws = 5\n',
    '[dataset.sampling]\nsize = "big"\n',
    '[dataset.sampling]\nfov_deg = [80.0, 10.0]\n',
    '[dataset.realism]\nskies = ["green"]\n',
    '[dataset.realism]\njpeg_quality = 500\n',
    '[dataset]\nsampling = 3\n',
    '[dataset.sampling]\nunknown_knob = 1\n',
    'dataset = "x"\n',
    '[[views]]\nname = "v"\n',
)


EXPERIMENT_BODIES = (
    '[[datasets]]\npath = "nowhere"\n[configurations.a]\n',
    '[[datasets]]\npath = "."\n[configurations.a]\noverrides = { chunk = "x" }\n',
    '[[datasets]]\nname = "a"\n[configurations.a]\n',
    '[configurations.a]\npreset = "fast"\n',
    '[[datasets]]\npath = "."\n[configurations.a]\nprior = "psychic"\n',
    '[[datasets]]\nch1 = "validation"\nbogus = 1\n[configurations.a]\n',
)


def _toml_files(work: str, rng: np.random.Generator, texts: list[str], prefix: str) -> list[str]:
    """The texts written as ``prefix<i>.toml``, a quarter of them with damaged bytes."""
    paths = []
    for i, text in enumerate(texts):
        data = text.encode()
        if rng.random() < 0.25:
            data = _mutate_bytes(data, rng)
        path = os.path.join(work, f"{prefix}{i}.toml")
        with open(path, "wb") as f:
            f.write(data)
        paths.append(path)
    return paths


def _scene_files(work: str, rng: np.random.Generator, dems: list[str], n: int) -> list[str]:
    """Scene files for ``skyrender dataset``: damaged DEMs, bad tables and values, garbled TOML."""
    texts = [f'dem = "{dems[int(rng.integers(len(dems)))]}"\n{SCENE_BODIES[int(rng.integers(len(SCENE_BODIES)))]}'
             for _ in range(n)]
    return _toml_files(work, rng, texts, "scene")


def _experiment_files(work: str, rng: np.random.Generator, n: int) -> list[str]:
    """Experiment configs: no datasets, unknown fields, folders that are not datasets, garbled TOML."""
    return _toml_files(work, rng, [EXPERIMENT_BODIES[int(rng.integers(len(EXPERIMENT_BODIES)))] for _ in range(n)],
                       "experiment")


def make_cases(work: str, n: int, seed: int, valid_model: str) -> list[Case]:
    """About ``n`` cases in the work directory ``work`` (inputs written there)."""
    rng = np.random.default_rng(seed)
    image = os.path.join(work, "photo.png")
    n_dem, n_img, n_model = int(n * 0.4), int(n * 0.35), int(n * 0.08)
    images = _image_files(work, rng, n_img)
    dems = _dem_files(work, rng, n_dem)
    models = _model_dirs(work, rng, valid_model, n_model)
    cases = []
    for d in dems:
        cases.append(Case(f"render --dem {os.path.basename(d)}", ["render", "--dem", d, "--x", "600", "--y", "600",
                                                                  "--height", "2", "--pan", "45", "--tilt", "0",
                                                                  "--swing", "0", "--fov", "50", "--size", "32x24",
                                                                  "--out", "r.png", "--json"], ("r.png",)))
    for d in dems[::4]:
        cases.append(Case(f"mesh {os.path.basename(d)}", ["mesh", d, "--out", "t.ply"], ("t.ply", "t.xml")))
    for folder, bounds in _dem_folders(work, rng, dems):
        cases.append(Case(f"mesh folder {os.path.basename(folder)} {bounds or ''}".strip(),
                          ["mesh", folder, "--out", "t.ply"] + (["--dem-bounds", bounds] if bounds else []),
                          ("t.ply", "t.xml")))
    for img in images:
        cases.append(Case(f"skyline {os.path.basename(img)}", ["skyline", img, "--json"]))
    localize = ["localize", image, "--model", valid_model, "--height", "2", "--fov", "50", "--json"]
    for sky in _skyline_files(work, rng, max(12, n // 40)):
        cases.append(Case(f"localize --skyline {os.path.basename(sky)}", [*localize, "--skyline", sky]))
    for i, img in enumerate(images[:: max(1, len(images) // max(6, n // 80))]):
        option = ("--sky-mask", "--terrain-mask")[i % 2]
        cases.append(Case(f"localize {option} {os.path.basename(img)}", [*localize, option, img]))
    for scene in _scene_files(work, rng, dems[::6], max(2, n // 40)):
        cases.append(Case(f"dataset {os.path.basename(scene)}", ["dataset", scene, "--n", "1", "--out", "ds", "--quiet"],
                          ("ds",)))
    for config in _experiment_files(work, rng, max(2, n // 60)):
        cases.append(Case(f"experiment {os.path.basename(config)}", ["experiment", config, "--out", "res", "--quiet"],
                          ("res",)))
    for m in models:
        cases.append(Case(f"localize --model {os.path.basename(m)}", ["localize", image, "--model", m, "--height", "2",
                                                                     "--fov", "50", "--json"]))
    cases += _bad_flags(rng, dems[0], image, valid_model)
    return cases[:n] if len(cases) > n else cases


def run_case(case: Case, work: str) -> Outcome:
    """Run one case in a fresh output directory under ``work``."""
    from ..cli import main
    from ..io import captured_stderr

    out_dir = tempfile.mkdtemp(dir=work, prefix="out")
    py_err = io.StringIO()
    cwd = os.getcwd()
    before = set(os.listdir(out_dir))
    t = time.perf_counter()
    os.chdir(out_dir)
    try:
        with captured_stderr() as err, contextlib.redirect_stderr(py_err), contextlib.redirect_stdout(io.StringIO()):
            try:
                code = main(case.argv)
            except SystemExit as exc:  # a case may exit directly
                code = exc.code if isinstance(exc.code, int) else 1
    finally:
        os.chdir(cwd)
    seconds = time.perf_counter() - t
    err_text = py_err.getvalue() + err["text"]
    extra = sorted(set(os.listdir(out_dir)) - before - set(case.outputs))
    if code != 0:  # a failed command must leave no partial outputs behind
        extra += [o for o in case.outputs if os.path.exists(os.path.join(out_dir, o))]
    shutil.rmtree(out_dir, ignore_errors=True)
    return Outcome(case, code, err_text, seconds, extra)


def fuzz(n: int = 1000, seed: int = 0, limit_s: float = 20.0, progress: bool = True) -> dict:
    """Run about ``n`` seeded cases; returns counts, failures and seconds."""
    from ..dem import load_dem
    from ..model import ModelParams, PeakParams, build_model, save_model

    t0 = time.perf_counter()
    work = tempfile.mkdtemp(prefix="skyrender-fuzz-")
    try:
        model_dir = os.path.join(work, "valid_model")
        dem = load_dem("builtin:jacksboro")
        save_model(build_model(dem, ModelParams(peaks=PeakParams(1800.0, 650.0))), model_dir)
        cases = make_cases(work, n, seed, model_dir)
        failures = []
        for i, case in enumerate(cases):
            outcome = run_case(case, work)
            why = outcome.failure(limit_s)
            if why:
                failures.append({"case": case.name, "argv": case.argv, "why": why})
            if progress and (i + 1) % 100 == 0:
                print(f"  {i + 1}/{len(cases)} cases, {len(failures)} failures", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return {"cases": len(cases), "failures": failures, "seconds": time.perf_counter() - t0, "seed": seed}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--limit-s", type=float, default=20.0, help="seconds a case may take")
    args = parser.parse_args(argv)
    report = fuzz(args.n, args.seed, args.limit_s)
    for f in report["failures"]:
        print(f"FAIL {f['case']}: {f['why']}")
    print(f"{report['cases']} cases, {len(report['failures'])} failures, {report['seconds']:.0f} s (seed {report['seed']})")
    return 1 if report["failures"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
