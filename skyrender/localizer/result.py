"""What a localization returns: :class:`LocalizationResult` (the pose or an abstention, its confidence, the
places it refined) and the search's record, :class:`LocalizeStats` (per-stage seconds and memory, hypotheses,
every refined pose)."""

from __future__ import annotations

import resource
import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from ..camera import Intrinsics, horizontal_fov, project
from .confidence import distinct_places


def peaks_in_view(model, pose, intrinsics, skyline=None, curvature: bool = True, on_skyline_px: float = 4.0):
    """Model feature points a pose sees inside the image, with their projections.

    ``pose``: (x, y, z, pan, tilt, swing), m and deg (README, Conventions); ``intrinsics``: the image's;
    ``curvature``: the earth's curvature and refraction applied as the renderer applies them.
    Returns (rows, uv, distance_m): feature-table rows, (n, 2) image points (px) and
    horizontal distances (m). With a ``skyline`` (W,) (v, px: the one rendered from ``pose``), only
    points on it (within ``on_skyline_px``) are kept: the peaks that make the skyline, not those
    hidden behind nearer terrain.
    """
    f = model.features
    uv, front = project(f.xyz, pose, intrinsics, curvature)
    W, H = intrinsics.width, intrinsics.height
    ok = front & (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)
    if skyline is not None:
        col = np.clip(np.nan_to_num(uv[:, 0]), 0, W - 1).astype(np.int64)
        with np.errstate(invalid="ignore"):
            ok &= np.abs(uv[:, 1] - skyline[col]) <= on_skyline_px
    rows = np.flatnonzero(ok)
    dist = np.hypot(f.x[rows] - pose[0], f.y[rows] - pose[1])
    return rows, uv[rows], dist


@dataclass
class LocalizeStats:
    generated: int = 0
    evaluated: int = 0
    rejected: dict = field(default_factory=lambda: {"residual": 0, "geometry": 0, "prior": 0,
                                                    "skyline_limit": 0, "interfeature_visibility": 0})
    verified: int = 0
    horizon_poses: int = 0  # of the verified, poses from the far-horizon search
    refined: int = 0
    best_score: float | None = None  # the winner's refined score (px)...
    runner_up_score: float | None = None  # ...and the runner-up's (the confidence's margin)
    # the answer's smallest margin on a part of the skyline (:func:`.confidence.answer_part_margin`)
    part_margin: float | None = None
    seconds: dict = field(default_factory=dict)
    peak_mb: dict = field(default_factory=dict)  # stage -> the process's peak RSS (MB) when it first reached it
    # the three-point search chunk by chunk: hypotheses solved, best verified and refined scores so far
    # (px, None: none yet), whether a pose was accepted
    rounds: list = field(default_factory=list)
    # every refined candidate, in the order refined: [x, y, z, pan, tilt, swing, f_px, refined score
    # (px)]; the places an analyst would check next, and what the diagnostics compare with the truth
    refined_poses: list = field(default_factory=list)
    refined_slopes: list = field(default_factory=list)  # the ground's slope (deg) under each refined pose
    searched_width: int | None = None  # the skyline's columns the search ran on (LocalizeParams.search_width)
    # the second opinion's best place, when one was asked (:func:`.pipeline._second_opinion`): its pose as refined_poses'
    # rows are, the distance (m) from the answer's and the second search's seconds
    second_opinion: dict | None = None

    def add_time(self, stage: str, seconds: float) -> None:
        self.seconds[stage] = self.seconds.get(stage, 0.0) + seconds

    @contextmanager
    def timed(self, stage: str):
        """``with stats.timed("verification"):`` adds the block's wall seconds to that stage."""
        tick, before = time.perf_counter(), peak_rss_mb()
        try:
            yield
        finally:
            self.add_time(stage, time.perf_counter() - tick)
            after = peak_rss_mb()
            if after > before:  # this stage raised the peak
                self.peak_mb[stage] = max(self.peak_mb.get(stage, 0.0), after)

    def to_dict(self) -> dict:
        solve = self.seconds.get("pose_solver", 0.0)
        return {"generated": self.generated, "evaluated": self.evaluated, "rejected": dict(self.rejected),
                "rejected_share": {k: (v / self.evaluated if self.evaluated else 0.0) for k, v in self.rejected.items()},
                "verified": self.verified, "horizon_poses": self.horizon_poses, "refined": self.refined,
                "best_score": self.best_score, "runner_up_score": self.runner_up_score, "part_margin": self.part_margin,
                "seconds": {k: round(v, 4) for k, v in self.seconds.items()},
                "peak_mb": {k: round(v, 1) for k, v in self.peak_mb.items()}, "rounds": list(self.rounds),
                "refined_poses": [list(r) for r in self.refined_poses], "refined_slopes": list(self.refined_slopes),
                "searched_width": self.searched_width, "second_opinion": self.second_opinion,
                "hypotheses_per_second": self.evaluated / solve if solve > 0 else 0.0}


@dataclass
class LocalizationResult:
    """Outcome of :func:`.pipeline.localize`. ``pose`` is (x, y, z, pan, tilt, swing) or None when abstained."""

    status: str
    pose: np.ndarray | None
    fov: float | None
    confidence: float
    seconds: float
    hypotheses: int
    stats: LocalizeStats
    intrinsics: Intrinsics | None = None
    image_skyline: np.ndarray | None = None
    rendered_skyline: np.ndarray | None = None
    crs: str | None = None
    lonlat: tuple[float, float] | None = None

    @property
    def localized(self) -> bool:
        return self.status == "localized"

    def to_json(self) -> dict:
        if not self.localized:
            return {"status": "abstained", "seconds": round(self.seconds, 3), "hypotheses": self.hypotheses}
        x, y, z, pan, tilt, swing = (float(v) for v in self.pose)
        lon, lat = self.lonlat if self.lonlat is not None else (None, None)
        return {"status": "localized", "x": x, "y": y, "z": z, "pan": pan, "tilt": tilt, "swing": swing,
                "fov": self.fov, "lat": lat, "lon": lon, "crs": self.crs, "confidence": round(self.confidence, 4),
                "seconds": round(self.seconds, 3), "hypotheses": self.hypotheses}

    def peaks_in_view(self, model, curvature: bool = True) -> list[dict]:
        """The model's peaks on the skyline rendered from the answer's pose (:func:`peaks_in_view`): which
        summits the photo shows. Each a dict: ``id`` (the model's peak id), ``x``, ``y`` (m, the world frame),
        ``elevation_m``, ``lat``/``lon`` (WGS 84, where the model's DEM has a CRS; else None), ``distance_m``
        (horizontal, from the camera), ``bearing_deg`` (clockwise from grid north), ``u``, ``v`` (px, where it
        stands in the photo), ``major``; left to right in the photo. Empty when it abstained."""
        if not self.localized or self.rendered_skyline is None:
            return []
        rows, uv, dist = peaks_in_view(model, self.pose, self.intrinsics, self.rendered_skyline, curvature)
        f, dem = model.features, model.dem
        lon, lat = (dem.to_lonlat(f.x[rows], f.y[rows]) if dem.crs is not None
                    else (np.full(len(rows), np.nan),) * 2)
        bearing = np.degrees(np.arctan2(f.x[rows] - self.pose[0], f.y[rows] - self.pose[1])) % 360.0
        out = []
        for i in np.argsort(uv[:, 0], kind="stable"):
            j = rows[i]
            out.append({"id": int(f.id[j]), "x": float(f.x[j]), "y": float(f.y[j]), "elevation_m": float(f.z[j]),
                        "lat": None if np.isnan(lat[i]) else float(lat[i]),
                        "lon": None if np.isnan(lon[i]) else float(lon[i]),
                        "distance_m": float(dist[i]), "bearing_deg": float(bearing[i]),
                        "u": float(uv[i, 0]), "v": float(uv[i, 1]), "major": bool(f.major[j])})
        return out

    def places(self, k: int, apart_m: float, dem=None) -> list[dict]:
        """The best ``k`` distinct places among the refined poses (``stats.refined_poses``), each farther than
        ``apart_m`` (m) from those before it: the answer's first (given or withheld: the photo confidence's
        runner-up is the second where ``apart_m`` is its distance), then by refined score. Each is a dict of its
        pose (x, y, z m; pan, tilt, swing, fov deg), ``lat``/``lon`` (WGS 84, where ``dem`` has a CRS; else None),
        ``score_px`` (its refined score: the mean column misfit, px of the searched skyline,
        ``stats.searched_width`` wide), ``from_first_m`` and, for the first only, ``confidence`` (the
        answer's, whether it reached the threshold or not; the others' have none). The places an analyst
        checks when the localizer abstains, or doubts its answer."""
        refined = np.asarray(self.stats.refined_poses, np.float64).reshape(-1, 8)
        if k < 1 or not len(refined):
            return []
        first = None
        if self.localized:  # the answer need not be the best-scoring refined pose (an accepted one, a slope bound)
            first = int(np.argmin(np.hypot(*(refined[:, :2] - np.asarray(self.pose[:2], np.float64)).T)))
        picked = refined[distinct_places(refined, k, apart_m, first)]
        width = self.intrinsics.width if self.intrinsics is not None else None
        lon, lat = (dem.to_lonlat(picked[:, 0], picked[:, 1]) if dem is not None and dem.crs is not None
                    else (np.full(len(picked), np.nan),) * 2)
        out = []
        for i, p in enumerate(picked):
            place = {"rank": i + 1, **dict(zip(("x", "y", "z", "pan", "tilt", "swing"), (float(v) for v in p[:6]))),
                     "fov": horizontal_fov(width, p[6]) if width else None,
                     "lat": float(lat[i]) if np.isfinite(lat[i]) else None,
                     "lon": float(lon[i]) if np.isfinite(lon[i]) else None,
                     "score_px": float(p[7]), "from_first_m": float(np.hypot(*(p[:2] - picked[0, :2])))}
            if i == 0:
                place["confidence"] = round(self.confidence, 4)
            out.append(place)
        return out


def peak_rss_mb() -> float:
    """This process's peak resident memory so far (MB): ``VmHWM`` of ``/proc/self/status``
    (``ru_maxrss`` also counts the process it was forked from, when larger), else ``ru_maxrss``."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
