"""Data sets: real photographs with true skylines (and, for CH1, true positions),
and the fixed training/validation split of them."""

from .real_photos import PhotoItem, load_split, photo_items, truth_from_mask, truth_from_red_line

__all__ = ["PhotoItem", "load_split", "photo_items", "truth_from_mask", "truth_from_red_line"]
