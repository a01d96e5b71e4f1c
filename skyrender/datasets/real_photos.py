"""Real photographs of ``../shared/data/photos`` with their true skylines, and the split.

Sets (see that folder's README): ``web`` (8 Web photos, red-line truth), ``web_train``
(64 more Web photos), ``geopose3k`` (2 photos, masks) and ``ch1`` (133 CH1 photos with
masks, focal lengths and true camera positions).

The training/validation split is fixed in ``experiments/photos/split.json`` and made by
:func:`make_split`, never at random: CH1 photos are grouped by *place* (cameras chained
within 2 km of each other, so a burst of photos from one spot, and the spots of one
hike, stay together) and whole places go to one side; the Web training set has no
positions, so it is split in two contiguous blocks of its numbering (web001-web044
train, web045-web064 validation). ``web`` and ``geopose3k`` are never trained on: they
are held out, like the validation side. A *dev* part of the training side (the CH1
training places but the largest, and web035-web044) is kept from the network: the
boundary search and the confidence are fitted on it, and training set-ups are compared
on it, so that nothing is chosen by looking at the validation side.

``python -m skyrender.datasets.real_photos --write-split`` rewrites the split file.
"""

from __future__ import annotations

import argparse
import csv
import glob
import json
import os
from dataclasses import dataclass

import numpy as np

from ..features.skyline import skyline_of_terrain

REPO = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", ".."))
DEFAULT_PHOTOS = os.path.normpath(os.path.join(REPO, "..", "shared", "data", "photos"))
SPLIT_FILE = os.path.join(REPO, "experiments", "photos", "split.json")
PLACE_LINK_KM = 2.0  # cameras chained within this distance are one place
VALIDATION_SHARE = 0.45  # of CH1 photos, by whole places
WEB_TRAIN_LAST = 44  # web001..web044 train, web045..web064 validation
WEB_DEV_FIRST = 35  # of those, web035..web044 are dev


@dataclass(frozen=True)
class PhotoItem:
    """One real photo: ``key`` (``set/id``), its image path, its truth (a sky mask or a
    red-line image) and, for CH1, the true camera position and focal length (px)."""

    key: str
    image_path: str
    truth_path: str
    truth_kind: str  # "mask" (white = terrain) or "red_line"
    lat: float | None = None
    lon: float | None = None
    focal_px: float | None = None

    def truth_mask(self) -> np.ndarray:
        """(H, W) float32 P(terrain) for training: 1 terrain, 0 sky, 0.5 unknown (red-line
        columns without a mark)."""
        import cv2

        if self.truth_kind == "mask":
            return (cv2.imread(self.truth_path, cv2.IMREAD_GRAYSCALE) > 127).astype(np.float32)
        line = truth_from_red_line(cv2.imread(self.truth_path)[..., ::-1])
        H = cv2.imread(self.truth_path).shape[0]
        v = np.arange(H)[:, None] + 0.5
        mask = (v >= line[None, :]).astype(np.float32)
        mask[:, ~np.isfinite(line)] = 0.5
        return mask

    def truth_skyline(self) -> np.ndarray:
        """(W,) true skyline, v per column (README, Conventions); NaN where unknown."""
        import cv2

        if self.truth_kind == "mask":
            return truth_from_mask(cv2.imread(self.truth_path, cv2.IMREAD_GRAYSCALE))
        return truth_from_red_line(cv2.imread(self.truth_path)[..., ::-1])


def truth_from_red_line(gt_rgb: np.ndarray) -> np.ndarray:
    """v per column of the top pure-red (255, 0, 0) pixel, + 0.5; NaN where none."""
    red = (gt_rgb[..., 0] >= 200) & (gt_rgb[..., 1] < 60) & (gt_rgb[..., 2] < 60)
    v = np.argmax(red, axis=0).astype(float) + 0.5
    v[~red.any(axis=0)] = np.nan
    return v


def truth_from_mask(mask: np.ndarray) -> np.ndarray:
    """Top edge of the first terrain (white: CH1 and GeoPose3K masks) pixel per column; NaN where none."""
    return skyline_of_terrain(mask > 127)


def photo_items(data_dir: str = DEFAULT_PHOTOS) -> list[PhotoItem]:
    """Every photo with truth under ``data_dir``, in a fixed order (set, then id)."""
    items = []
    for gt in sorted(glob.glob(os.path.join(data_dir, "web", "*_gt.png"))):
        name = os.path.basename(gt)[: -len("_gt.png")]
        items.append(PhotoItem(f"web/{name}", gt.replace("_gt.png", ".png"), gt, "red_line"))
    for gt in sorted(glob.glob(os.path.join(data_dir, "web_train", "*_gt.png"))):
        name = os.path.basename(gt)[: -len("_gt.png")]
        items.append(PhotoItem(f"web_train/{name}", gt.replace("_gt.png", ".jpg"), gt, "red_line"))
    for d in sorted(glob.glob(os.path.join(data_dir, "geopose3k", "*"))):
        items.append(PhotoItem("geopose3k/" + os.path.basename(d), os.path.join(d, "original.png"),
                               os.path.join(d, "mask.png"), "mask"))
    index = os.path.join(data_dir, "ch1", "index.csv")
    if os.path.exists(index):
        with open(index, newline="") as f:
            for row in csv.DictReader(f):
                d = os.path.join(data_dir, "ch1", row["id"])
                items.append(PhotoItem(f"ch1/{row['id']}", os.path.join(d, "photo.jpg"), os.path.join(d, "mask.png"),
                                       "mask", float(row["lat"]), float(row["lon"]), float(row["focal_px"])))
    return items


def local_km(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """(N, 2) east/north kilometres of lat/lon degrees on a local equirectangular plane
    (good to a fraction of a percent over the few hundred km of one data set)."""
    lat0 = np.radians(np.mean(lat))
    return np.column_stack([np.asarray(lon) * 111.32 * np.cos(lat0), np.asarray(lat) * 110.57])


def places(lat: np.ndarray, lon: np.ndarray, link_km: float = PLACE_LINK_KM) -> np.ndarray:
    """(N,) place label per camera: single-linkage clusters at ``link_km``, numbered from 0
    in order of first appearance."""
    from scipy.cluster.hierarchy import fcluster, linkage

    if len(lat) == 1:
        return np.zeros(1, dtype=int)
    raw = fcluster(linkage(local_km(lat, lon), "single"), link_km, "distance")
    _, first, inverse = np.unique(raw, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))
    return order[inverse]


def make_split(items: list[PhotoItem]) -> dict:
    """The split as a dict ``{"rule", "photos": {key: {"side", "place"}}}`` (see module doc).

    CH1 places are taken largest first, each to the side further below its share
    (validation :data:`VALIDATION_SHARE`), ties to training.
    """
    photos: dict[str, dict] = {}
    for it in items:
        set_name, name = it.key.split("/", 1)
        if set_name == "web_train":
            number = int(name[3:])
            side = "validation" if number > WEB_TRAIN_LAST else ("dev" if number >= WEB_DEV_FIRST else "train")
            photos[it.key] = {"side": side, "place": f"web/{name}"}
        elif set_name in ("web", "geopose3k"):
            photos[it.key] = {"side": "heldout", "place": it.key}
    ch1 = [it for it in items if it.key.startswith("ch1/")]
    if ch1:
        label = places(np.array([it.lat for it in ch1]), np.array([it.lon for it in ch1]))
        sizes = np.bincount(label)
        counts = {"train": 0, "validation": 0}
        side_of = {}
        for p in sorted(range(len(sizes)), key=lambda p: (-sizes[p], p)):
            total = max(sum(counts.values()), 1)
            side = "validation" if counts["validation"] / total < VALIDATION_SHARE and counts["train"] > 0 else "train"
            side_of[p] = side
            counts[side] += sizes[p]
        training = [p for p in side_of if side_of[p] == "train"]
        largest = max(training, key=lambda p: (sizes[p], -p))
        for p in training:
            if p != largest:
                side_of[p] = "dev"
        for it, p in zip(ch1, label):
            photos[it.key] = {"side": side_of[p], "place": f"ch1/place{p:02d}"}
    rule = (f"CH1: places = cameras chained within {PLACE_LINK_KM} km; places largest first to the side "
            f"further below its share (validation {VALIDATION_SHARE:.0%}); of the training places all but the "
            f"largest are dev. web_train: web001-web{WEB_DEV_FIRST - 1:03d} train, web{WEB_DEV_FIRST:03d}-"
            f"web{WEB_TRAIN_LAST:03d} dev, the rest validation. web, geopose3k: held out (never trained on).")
    return {"rule": rule, "photos": photos}


def load_split(path: str = SPLIT_FILE) -> dict[str, str]:
    """``{key: side}`` from the committed split file (side: train, dev, validation, heldout)."""
    with open(path) as f:
        return {k: v["side"] for k, v in json.load(f)["photos"].items()}


def split_places(path: str = SPLIT_FILE) -> dict[str, str]:
    """``{key: place}`` from the committed split file: a CH1 photo's place (``ch1/placeNN``: cameras chained within
    :data:`PLACE_LINK_KM`), each Web or GeoPose3K photo a place of its own (they have no positions)."""
    with open(path) as f:
        return {k: v["place"] for k, v in json.load(f)["photos"].items()}


def items_on_side(side: str, data_dir: str = DEFAULT_PHOTOS, split_path: str = SPLIT_FILE) -> list[PhotoItem]:
    """The photos of one side of the committed split that exist under ``data_dir``."""
    split = load_split(split_path)
    return [it for it in photo_items(data_dir) if split.get(it.key) == side]


DEV_FOLDS = 2


def dev_fold_of(split_path: str = SPLIT_FILE, folds: int = DEV_FOLDS) -> dict[str, int]:
    """``{key: fold}`` of the dev photos, whole places to a fold: each set's dev places in name
    order, dealt round-robin (CH1 place01 -> 0, place02 -> 1, ...; web035 -> 0, web036 -> 1, ...).
    For cross-fitting: a network trained on the training side plus one fold is judged on the
    others, which it never saw, so dev stays a measure of unseen places."""
    with open(split_path) as f:
        photos = json.load(f)["photos"]
    dev_places = sorted({v["place"] for v in photos.values() if v["side"] == "dev"})
    fold: dict[str, int] = {}
    for set_name in sorted({p.split("/")[0] for p in dev_places}):
        for n, place in enumerate(p for p in dev_places if p.split("/")[0] == set_name):
            fold[place] = n % folds
    return {k: fold[v["place"]] for k, v in photos.items() if v["side"] == "dev"}


def items_in_dev_fold(fold: int, data_dir: str = DEFAULT_PHOTOS, split_path: str = SPLIT_FILE,
                      folds: int = DEV_FOLDS) -> list[PhotoItem]:
    """The dev photos of one fold (:func:`dev_fold_of`) that exist under ``data_dir``."""
    of = dev_fold_of(split_path, folds)
    return [it for it in photo_items(data_dir) if of.get(it.key) == fold]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Write the fixed training/validation split of the real photos.")
    parser.add_argument("--data", default=DEFAULT_PHOTOS)
    parser.add_argument("--write-split", action="store_true", help=f"write {os.path.relpath(SPLIT_FILE, REPO)}")
    args = parser.parse_args(argv)
    split = make_split(photo_items(args.data))
    sides = [v["side"] for v in split["photos"].values()]
    for s in ("train", "dev", "validation", "heldout"):
        print(f"{s}: {sides.count(s)} photos")
    if args.write_split:
        with open(SPLIT_FILE, "w") as f:
            json.dump(split, f, indent=1, sort_keys=True)
            f.write("\n")
        print(f"wrote {SPLIT_FILE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
