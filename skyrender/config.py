"""Parameter dataclasses to and from plain dicts (JSON, TOML).

``LocalizeParams``, ``ModelParams`` and their nested parameter groups are frozen
dataclasses; an experiment config sets any field by name, nested groups as tables::

    [configurations.photo-fewer-tilts]
    preset = "photo"
    overrides = { final_refinements = 4, horizon = { tilts = [0, 10, 20] } }
"""

from __future__ import annotations

import dataclasses
import typing

from .errors import InputError


def params_to_dict(params) -> dict:
    """A parameter dataclass as a dict of plain values (tuples become lists; JSON/TOML safe)."""

    def plain(value):
        if dataclasses.is_dataclass(value):
            return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
        if isinstance(value, (tuple, list)):
            return [plain(v) for v in value]
        return value

    return plain(params)


def params_from_dict(cls, data: dict, base=None, where: str = ""):
    """An instance of the frozen dataclass ``cls`` with the fields in ``data`` set on
    ``base`` (default: ``cls()``). Nested dataclass fields take a dict of their own fields;
    lists become tuples where the default is a tuple. An unknown field or a value of the
    wrong kind is an :class:`InputError` naming it (``where`` prefixes the name)."""
    base = cls() if base is None else base
    if not isinstance(data, dict):
        raise InputError(f"{where or cls.__name__}: expected a table of fields, got {type(data).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    changes = {}
    for name, value in data.items():
        if name not in fields:
            raise InputError(f"unknown parameter '{where}{name}' of {cls.__name__} (known: {', '.join(fields)})")
        current = getattr(base, name)
        if dataclasses.is_dataclass(current):
            changes[name] = params_from_dict(type(current), value, current, f"{where}{name}.")
            continue
        changes[name] = _coerce(value, current, hints.get(name), f"{where}{name}")
    return dataclasses.replace(base, **changes)


def _coerce(value, current, hint, name: str):
    """``value`` in the kind of ``current`` (the field's present value)."""
    if isinstance(current, tuple) or (current is None and isinstance(value, list)):
        if not isinstance(value, (list, tuple)):
            raise InputError(f"parameter {name!r} takes a list, got {value!r}")
        return tuple(tuple(v) if isinstance(v, list) else v for v in value)
    if isinstance(current, bool):
        if not isinstance(value, bool):
            raise InputError(f"parameter {name!r} takes true or false, got {value!r}")
        return value
    if isinstance(current, (int, float)) and not isinstance(current, bool):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"parameter {name!r} takes a number, got {value!r}")
        return float(value) if isinstance(current, float) else value
    if isinstance(current, str) and not isinstance(value, str):
        raise InputError(f"parameter {name!r} takes a string, got {value!r}")
    return value
