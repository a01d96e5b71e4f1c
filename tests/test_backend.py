"""Mitsuba variant and libLLVM selection."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from skyrender import backend
from skyrender.errors import InputError


@pytest.mark.parametrize("path, major", [
    ("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", 19),
    ("/usr/lib/x86_64-linux-gnu/libLLVM-15.so", 15),
    ("/usr/lib/x86_64-linux-gnu/libLLVM-16.so.1", 16),
    ("/usr/lib/llvm-18/lib/libLLVM.so", 18),
    ("/usr/lib/x86_64-linux-gnu/libLLVM-14.0.6.so.1", 14),
])
def test_llvm_version_is_read_from_the_file_name(path, major):
    assert backend.llvm_major_version(path) == major


def test_llvm_15_and_16_are_never_chosen(monkeypatch, tmp_path):
    for name in ("libLLVM-15.so", "libLLVM-16.so", "libLLVM.so.19.1"):
        (tmp_path / name).write_bytes(b"")
    monkeypatch.setattr(backend, "_LLVM_GLOBS", (str(tmp_path / "libLLVM*.so*"),))
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(tmp_path / "libLLVM-15.so"))
    assert backend.find_libllvm() == str(tmp_path / "libLLVM.so.19.1")
    (tmp_path / "libLLVM.so.19.1").unlink()
    assert backend.find_libllvm() is None


def test_unknown_variant_is_bad_input():
    with pytest.raises(InputError, match="unknown Mitsuba variant"):
        backend.requested_variant("opengl_rgb")


SCRIPT = """
import json, numpy as np
from affine import Affine
from skyrender.dem import DEM
from skyrender.camera import Intrinsics
from skyrender.render import Terrain, render_skylines
y, x = np.mgrid[0:40, 0:40]
z = 300 * np.exp(-((x - 20.0) ** 2 + (y - 10.0) ** 2) / 60.0) + 5 * np.sin(x / 3.0)
dem = DEM(z, Affine(50, 0, 0, 0, -50, 2000), None, "bump")
terrain = Terrain(dem)
pose = dem.camera_pose(1000, 200, 2, 0, 3, 2)
sky = render_skylines(terrain, pose, Intrinsics.from_fov(50, 24, 18))
print(json.dumps({"variant": terrain.variant, "sky": [None if v != v else float(v) for v in sky]}))
"""


def _run(variant: str) -> dict:
    env = dict(os.environ, SKYRENDER_VARIANT=variant)
    proc = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_scalar_fallback_renders_the_same_skyline():
    llvm, scalar = _run("llvm_ad_rgb"), _run("scalar_rgb")
    assert scalar["variant"] == "scalar_rgb"
    a = [v for v in llvm["sky"]]
    b = [v for v in scalar["sky"]]
    assert [v is None for v in a] == [v is None for v in b]
    assert max(abs(p - q) for p, q in zip(a, b) if p is not None) < 0.05
