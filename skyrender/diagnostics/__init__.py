"""Diagnostics on real photographs (what the localizer can hope for)."""
