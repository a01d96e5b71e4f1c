"""The ``skyrender`` command (``python -m skyrender``, and the console script).

Process settings that must precede numpy's import are made here, before :mod:`skyrender.cli`
(and with it numpy) is imported; everything else is :func:`skyrender.cli.main`.
"""

from __future__ import annotations

import os


def command_process_settings(environ=os.environ) -> None:
    """Defaults for the command's own process (a value already set is kept).

    ``NUMPY_MADVISE_HUGEPAGE=0``: numpy asks the kernel for transparent huge pages on every
    array of 4 MB or more. Where the kernel's THP defrag setting is ``madvise`` (Debian's and
    many cloud images' default) each such allocation may stall in direct memory compaction,
    and a fresh process allocates nearly all its memory anew (the measurements: README,
    *Command line*; ``experiments/scale/huge-pages-off/``).
    """
    environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")


def main() -> None:
    """Console-script entry: the process settings, then the command (:func:`skyrender.cli.run`)."""
    command_process_settings()
    from .cli import run

    run()


if __name__ == "__main__":
    main()
