"""Stages 3–4 — the localizer: hypotheses, pose fitting, constraints, verification,
refinement, confidence (Naval 2000, sections 2.2–2.6).

Entry point: :func:`localize` (photo + model -> :class:`LocalizationResult`).
Modules in pipeline order: ``hypotheses`` -> ``pose_solver`` -> ``constraints``
-> ``verification`` -> ``refinement`` -> ``confidence``; ``pipeline`` runs them.
"""

from .pipeline import LocalizationResult, LocalizeParams, LocalizeStats, localize

__all__ = ["localize", "LocalizationResult", "LocalizeParams", "LocalizeStats"]
