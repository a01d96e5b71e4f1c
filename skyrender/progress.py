"""Progress bars on stderr (tqdm), for the stages a user waits minutes on."""

from __future__ import annotations


def progress(items, label: str, enabled: bool, total: int | None = None, unit: str = "it", leave: bool = True):
    """``items`` with a tqdm progress bar on stderr when ``enabled`` (``leave``: the bar stays when done);
    ``items`` themselves otherwise."""
    if not enabled:
        return items
    from tqdm import tqdm

    return tqdm(items, desc=label, unit=unit, total=total, leave=leave)
