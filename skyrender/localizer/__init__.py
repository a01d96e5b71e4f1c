"""Stages 3–4 — the localizer: hypotheses, pose fitting, constraints, verification,
refinement, confidence (Naval 2000, sections 2.2–2.6).

Entry point: :func:`localize` (photo + model -> :class:`LocalizationResult`).
Modules in pipeline order: ``hypotheses`` -> ``pose_solver`` -> ``constraints``
-> ``verification`` -> ``refinement`` -> ``confidence``; ``pipeline`` runs them, with the
parameters of ``params`` (the ``render`` and ``photo`` presets), and returns a ``result``.
"""

from .params import LocalizeParams
from .pipeline import localize
from .result import LocalizationResult, LocalizeStats

__all__ = ["localize", "LocalizationResult", "LocalizeParams", "LocalizeStats"]
