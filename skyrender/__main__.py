"""The ``skyrender`` command (``python -m skyrender``, and the console script).

Process settings that must precede numpy's import are made here, before :mod:`skyrender.cli`
(and with it numpy) is imported; everything else is :func:`skyrender.cli.main`.
"""

from __future__ import annotations

import os
import sys


def command_process_settings(environ=os.environ) -> None:
    """Defaults for the command's own process (a value already set is kept).

    ``NUMPY_MADVISE_HUGEPAGE=0``: numpy asks the kernel for transparent huge pages on every
    array of 4 MB or more. Where the kernel's THP defrag setting is ``madvise`` (Debian's and
    many cloud images' default) each such allocation may stall in direct memory compaction,
    and a fresh process allocates nearly all its memory anew. Measured on the 2-core development
    machine, each command alternated with and without: ``skyrender skyline`` on a 12.6-megapixel
    photo 6.5-8.8 s against 4.1-5.0 s; ``skyrender localize`` on a 1024 x 640 render 6.7-7.5 s
    against 5.0-5.2 s (the command's own seconds); the same results.
    """
    environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")


def main() -> None:
    """Console-script entry: the process settings, then the command."""
    command_process_settings()
    from .cli import main as cli_main

    sys.exit(cli_main())


if __name__ == "__main__":
    main()
