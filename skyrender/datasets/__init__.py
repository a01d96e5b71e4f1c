"""Data sets: real photographs with true skylines (and, for CH1, true positions) and the
fixed training/validation split of them (:mod:`.real_photos`); frozen synthetic datasets
rendered from a scene's recipe (:mod:`.synthetic`, ``skyrender dataset``)."""

from .real_photos import PhotoItem, load_split, photo_items, truth_from_mask, truth_from_red_line
from .synthetic import DatasetSpec, Realism, Sampling, dataset_spec, write_dataset

__all__ = ["DatasetSpec", "PhotoItem", "Realism", "Sampling", "dataset_spec", "load_split", "photo_items",
           "truth_from_mask", "truth_from_red_line", "write_dataset"]
