"""How often the face detector finds the rendered faces, by face size (issue 12's goal: 90 %
of frontal frames where the face spans at least 24 px)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.perception.faces.detect import DetectorParams, FaceDetector, matches_truth
from humimic.perception.faces.studio import FaceStudio, FaceView, size_to_distance
from humimic.world.names import EYE_HFOV_DEG

FRONTAL_LIMITS_DEG = (12.0, 10.0, 8.0)
"""Largest |yaw|, |pitch|, |roll| of a "frontal" view."""


def random_view(rng: np.random.Generator, distance: float, limits_deg=FRONTAL_LIMITS_DEG,
                max_offset_m: float | None = None) -> FaceView:
    """A view at ``distance`` with head angles uniform within ``limits_deg``, lighting between
    dim and bright, and the face anywhere in the central half of the image."""
    yaw, pitch, roll = (rng.uniform(-lim, lim) for lim in limits_deg)
    off = 0.1 * distance if max_offset_m is None else max_offset_m
    return FaceView(distance=float(distance), yaw_deg=yaw, pitch_deg=pitch, roll_deg=roll,
                    ambient=rng.uniform(0.15, 0.45), diffuse=rng.uniform(0.35, 0.75),
                    aim_offset=(rng.uniform(-off, off), rng.uniform(-off, off) * 0.6))


@dataclass
class RateTable:
    """Detections per (camera, size bin): hits and trials; false detections per frame."""

    bins: tuple[float, ...]
    hits: dict[tuple[str, int], int]
    trials: dict[tuple[str, int], int]
    false_detections: int = 0
    by_identity: dict[str, list[int]] | None = None
    """identity -> [hits, trials] over every camera and bin."""

    def rate(self, camera: str, b: int) -> float:
        n = self.trials.get((camera, b), 0)
        return self.hits.get((camera, b), 0) / n if n else float("nan")

    def overall(self, min_size: float = 24.0) -> float:
        keys = [k for k in self.trials if self.bins[k[1]] >= min_size]
        n = sum(self.trials[k] for k in keys)
        return sum(self.hits.get(k, 0) for k in keys) / n if n else float("nan")


def detection_rates(identities: list[str], cameras=("foveal", "wide"),
                    bins=(24.0, 28.0, 34.0, 44.0, 60.0, 90.0), per_bin: int = 4,
                    params: DetectorParams | None = None, seed: int = 0,
                    distances=(0.45, 4.5), progress=None) -> RateTable:
    """Render each identity ``per_bin`` times per size bin and camera (frontal views, sizes
    uniform in the bin) and count the frames where a detection lies on the face. Sizes a
    camera cannot show at ``distances`` (m) are skipped."""
    rng = np.random.default_rng(seed)
    det = FaceDetector(params or DetectorParams())
    table = RateTable(tuple(bins[:-1]), {}, {}, 0, {})
    for ident in identities:
        with FaceStudio(ident, tuple(f"L_{c}" for c in cameras), rng=rng) as studio:
            for cam in cameras:
                for b in range(len(bins) - 1):
                    for _ in range(per_bin):
                        size = rng.uniform(bins[b], bins[b + 1])
                        dist = size_to_distance(size, EYE_HFOV_DEG[cam])
                        if not distances[0] <= dist <= distances[1]:
                            continue
                        shot = studio.render(random_view(rng, dist), f"L_{cam}")
                        boxes = det.detect(shot.image)
                        ok = matches_truth(boxes, shot.center_px, shot.size_px)
                        key = (cam, b)
                        table.trials[key] = table.trials.get(key, 0) + 1
                        table.hits[key] = table.hits.get(key, 0) + int(ok.any())
                        table.false_detections += int((~ok).sum())
                        counts = table.by_identity.setdefault(ident, [0, 0])
                        counts[0] += int(ok.any())
                        counts[1] += 1
        if progress is not None:
            progress()
    return table
