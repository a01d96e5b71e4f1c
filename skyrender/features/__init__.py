"""Stage 2 — image features: the photo's skyline and its peaks.

Entry points: :func:`extract_skyline` (photo -> skyline + per-column
confidence), :func:`given_skyline` (a skyline or sky mask a person made for the photo, in place of
the extracted one) and :func:`skyline_peaks` (skyline -> the largest peaks).
"""

from .peaks import SkylinePeak, skyline_peaks
from .photo_io import as_rgb8, given_skyline, load_photo
from .skyline import ExtractedSkyline, SkylineParams, extract_skyline, sky_mask_of_skyline, skyline_of_terrain

__all__ = ["extract_skyline", "skyline_peaks", "load_photo", "as_rgb8", "given_skyline", "skyline_of_terrain",
           "sky_mask_of_skyline", "ExtractedSkyline", "SkylineParams", "SkylinePeak"]
