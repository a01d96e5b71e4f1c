"""Mitsuba 3 / Dr.Jit set-up: which variant runs, and which libLLVM it loads.

Dr.Jit's LLVM backend loads a system ``libLLVM`` at run time. LLVM 15 and 16
load but abort the whole process on the first kernel (``Cannot select:
fminimum``), which no ``try`` can catch, so we choose the library ourselves
*before* Dr.Jit is imported: ``DRJIT_LIBLLVM_PATH`` if it names LLVM >= 17,
else the newest LLVM >= 17 found in the usual places. Without one, the LLVM
variants are never touched and we fall back to ``scalar_rgb`` with a
one-line warning.

The variant is one setting: ``SKYRENDER_VARIANT`` (or ``--variant`` on the
command line); default ``llvm_ad_rgb``. No other module depends on which.
"""

from __future__ import annotations

import glob
import os
import re
import sys

from .errors import InputError

DEFAULT_VARIANT = "llvm_ad_rgb"
FALLBACK_VARIANT = "scalar_rgb"
SUPPORTED_VARIANTS = ("llvm_ad_rgb", "cuda_ad_rgb", "scalar_rgb")
MIN_LLVM_MAJOR = 17

_LLVM_GLOBS = (
    "/usr/lib/x86_64-linux-gnu/libLLVM*.so*",
    "/usr/lib/aarch64-linux-gnu/libLLVM*.so*",
    "/usr/lib/llvm-*/lib/libLLVM*.so*",
    "/usr/lib64/libLLVM*.so*",
    "/usr/local/lib/libLLVM*.so*",
    "/opt/homebrew/opt/llvm/lib/libLLVM*.dylib",
)

_active_variant: str | None = None


def llvm_major_version(path: str) -> int | None:
    """Major version encoded in a libLLVM file name (``libLLVM.so.19.1``,
    ``libLLVM-19.so``, ``/usr/lib/llvm-18/lib/libLLVM.so``), else None."""
    name = os.path.basename(path)
    m = re.search(r"libLLVM[-.](?:so\.)?(\d+)", name)
    if m is None:
        m = re.search(r"llvm-(\d+)", path)
    return int(m.group(1)) if m else None


def find_libllvm() -> str | None:
    """Path of a libLLVM that Dr.Jit can use safely (major >= 17), or None.

    An explicit ``DRJIT_LIBLLVM_PATH`` wins when it names a usable version.
    """
    explicit = os.environ.get("DRJIT_LIBLLVM_PATH")
    if explicit and os.path.exists(explicit):
        major = llvm_major_version(os.path.realpath(explicit)) or llvm_major_version(explicit)
        if major is None or major >= MIN_LLVM_MAJOR:
            return explicit
    candidates = []
    for pattern in _LLVM_GLOBS:
        for path in glob.glob(pattern):
            major = llvm_major_version(path)
            if major is not None and major >= MIN_LLVM_MAJOR and os.path.isfile(path):
                candidates.append((major, path))
    if not candidates:
        return None
    return max(candidates)[1]


def _warn(message: str) -> None:
    print(f"skyrender: warning: {message}", file=sys.stderr)


def requested_variant(variant: str | None = None) -> str:
    """The variant asked for: the argument, else ``SKYRENDER_VARIANT``, else the default."""
    name = variant or os.environ.get("SKYRENDER_VARIANT") or DEFAULT_VARIANT
    if name not in SUPPORTED_VARIANTS:
        raise InputError(
            f"unknown Mitsuba variant {name!r}; choose one of {', '.join(SUPPORTED_VARIANTS)}"
        )
    return name


def mitsuba(variant: str | None = None):
    """Import Mitsuba with a working variant set, and return the module.

    The first call decides the variant; later calls with no argument reuse it.
    The default variant falls back (with a one-line warning) to ``scalar_rgb`` when it
    cannot run; a variant asked for explicitly (``--variant`` or ``SKYRENDER_VARIANT``)
    that cannot run is an InputError instead of a silent change of backend.
    """
    global _active_variant
    if variant is None and _active_variant is not None:
        import mitsuba as mi

        return mi
    explicit = variant is not None or bool(os.environ.get("SKYRENDER_VARIANT"))
    name = requested_variant(variant)
    if name.startswith("llvm"):
        lib = find_libllvm()
        if lib is None:
            if explicit:
                raise InputError(f"Mitsuba variant {name} cannot run here: no libLLVM >= {MIN_LLVM_MAJOR} found "
                                 f"(install libllvm19), or choose --variant {FALLBACK_VARIANT}")
            _warn(
                f"no libLLVM >= {MIN_LLVM_MAJOR} found (install libllvm19); "
                f"using the slow {FALLBACK_VARIANT} variant"
            )
            name = FALLBACK_VARIANT
        else:
            os.environ["DRJIT_LIBLLVM_PATH"] = lib
    import mitsuba as mi

    try:
        mi.set_variant(name)
    except Exception as exc:  # an unavailable backend: refuse what was asked for, degrade the default
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if explicit:
            raise InputError(f"Mitsuba variant {name} cannot run here ({reason})") from None
        fallback = FALLBACK_VARIANT
        _warn(f"Mitsuba variant {name} unavailable ({reason}); using {fallback}")
        mi.set_variant(fallback)
        name = fallback
    _active_variant = name
    return mi


def active_variant() -> str:
    """The variant in use (initialising the default one if none is yet)."""
    mitsuba()
    return _active_variant  # type: ignore[return-value]


def is_jit(variant: str | None = None) -> bool:
    """True for the vectorized (LLVM/CUDA) variants, False for scalar ones."""
    return not (variant or active_variant()).startswith("scalar")
