"""Pictures for people: skylines and labels drawn over photographs."""

from __future__ import annotations

import numpy as np


def draw_skyline(image: np.ndarray, skyline: np.ndarray, colour=(255, 0, 0), thickness: int = 2) -> np.ndarray:
    """Copy of an (H, W, 3) RGB uint8 image with the skyline (v per column, NaN = none)
    drawn as a polyline; runs of NaN break the line."""
    import cv2

    out = np.ascontiguousarray(image.copy())
    u = np.arange(len(skyline)) + 0.5
    ok = np.isfinite(skyline)
    shift = 4  # OpenCV fixed-point sub-pixel drawing: 1/16 px
    for run in np.split(np.arange(len(skyline)), np.flatnonzero(np.diff(ok.astype(int))) + 1):
        run = run[ok[run]]
        if len(run) == 0:
            continue
        pts = np.round(np.stack([u[run], skyline[run]], 1) * (1 << shift)).astype(np.int32)
        cv2.polylines(out, [pts], False, colour, thickness, cv2.LINE_AA, shift)
    return out


def write_image(path, image: np.ndarray) -> None:
    """Write an RGB (or gray) uint8 image; InputError when the file cannot be written."""
    import os

    import cv2

    from .errors import InputError

    path = os.fspath(path)
    bgr = image[..., ::-1] if image.ndim == 3 else image
    try:
        ok = cv2.imwrite(path, np.ascontiguousarray(bgr))
    except cv2.error as exc:
        raise InputError(f"cannot write image {path}: {str(exc).strip().splitlines()[-1]}") from None
    if not ok:
        raise InputError(f"cannot write image {path} (unknown extension or unwritable location)")


def place_labels(anchors: list[tuple[int, int]], sizes: list[tuple[int, int]], shape: tuple[int, int],
                 gap: int = 3, tries: int = 6) -> list[tuple[int, int] | None]:
    """Text origins (x, y: the baseline's left end, px) for labels of the given sizes
    (w, h) near their anchors (u, v), in priority order, so that no two labels overlap
    and each lies within the image (H, W): first above-right of the anchor, then stacked
    further up, then to the left; None where no place is free (the label is dropped)."""
    H, W = shape
    taken: list[tuple[int, int, int, int]] = []
    out: list[tuple[int, int] | None] = []
    for (u, v), (w, h) in zip(anchors, sizes):
        spot = None
        for k in range(tries):
            for x in (u + 4, u - 4 - w):
                y = v - 8 - k * (h + gap)
                box = (x, y - h, x + w, y + gap)
                if box[0] < 0 or box[2] > W or box[1] < 0 or box[3] > H:
                    continue
                if all(box[2] <= t[0] or box[0] >= t[2] or box[3] <= t[1] or box[1] >= t[3] for t in taken):
                    spot = (x, y)
                    taken.append(box)
                    break
            if spot is not None:
                break
        out.append(spot)
    return out


#: Colours (RGB) of the places' skylines in :func:`localization_overlay`, by rank (the answer's place in the
#: answer's green where it was given).
PLACE_COLOURS = ((255, 140, 0), (0, 200, 255), (255, 0, 255), (255, 255, 255), (140, 90, 255))


def localization_overlay(image: np.ndarray, result, model, max_labels: int = 12,
                         places: list[tuple[int, np.ndarray]] = ()) -> np.ndarray:
    """The photo with the photo's skyline (red), the skyline rendered from the found
    pose (green) and the model peaks in view, labelled "id elevation distance"; with ``places``
    ((rank, skyline rendered from that place (W,)) of :meth:`LocalizationResult.places`) their skylines
    too, thin, each in its rank's colour (:data:`PLACE_COLOURS`) and named in a key at the top left:
    what an analyst compares by eye when the localizer abstains."""
    import cv2

    out = draw_skyline(image, result.image_skyline, (255, 0, 0), 2)
    keys = []
    for rank, skyline in places:
        if rank == 1 and result.pose is not None:
            continue  # the answer's: drawn below, in green
        colour = PLACE_COLOURS[(rank - 1) % len(PLACE_COLOURS)]
        out = draw_skyline(out, skyline, colour, 1)
        keys.append((f"place {rank}" + (" (withheld)" if rank == 1 else ""), colour))
    for i, (text, colour) in enumerate(keys):
        y = 48 + 18 * i
        cv2.putText(out, text, (10, y), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (40, 40, 40), 3, cv2.LINE_AA)
        cv2.putText(out, text, (10, y), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1, cv2.LINE_AA)
    if result.rendered_skyline is not None:
        out = draw_skyline(out, result.rendered_skyline, (0, 200, 0), 1)
    if result.pose is None:
        cv2.putText(out, "abstained", (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 0), 2, cv2.LINE_AA)
        return out
    from .localizer.result import peaks_in_view

    rows, uv, dist = peaks_in_view(model, result.pose, result.intrinsics, result.rendered_skyline)
    f = model.features
    order = np.argsort(-f.z[rows])[:max_labels]  # highest first: a lesser peak yields its place
    labels = [f"P{int(f.id[rows[i]])} {f.z[rows[i]]:.0f}m {dist[i] / 1000:.1f}km" for i in order]
    sizes = [cv2.getTextSize(t, cv2.FONT_HERSHEY_SIMPLEX, 0.4, 1)[0] for t in labels]
    anchors = [tuple(int(round(c)) for c in uv[i]) for i in order]
    spots = place_labels(anchors, sizes, out.shape[:2])
    for (u, v), (w, _), spot in zip(anchors, sizes, spots):  # markers and leader lines first, text on top
        cv2.drawMarker(out, (u, v), (255, 255, 0), cv2.MARKER_TRIANGLE_UP, 10, 2)
        if spot is not None and (abs(spot[1] - (v - 8)) > 1 or abs(spot[0] - (u + 4)) > 1):  # moved off its peak
            x, y = spot
            cv2.line(out, (u, v - 6), (min(max(u, x), x + w), y + 2), (255, 255, 0), 1, cv2.LINE_AA)
    for label, spot in zip(labels, spots):
        if spot is not None:
            cv2.putText(out, label, spot, cv2.FONT_HERSHEY_SIMPLEX, 0.4, (40, 40, 40), 3, cv2.LINE_AA)  # outline
            cv2.putText(out, label, spot, cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 0), 1, cv2.LINE_AA)
    return out
