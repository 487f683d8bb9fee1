"""Visibility ground truth: per eye-camera frame and target, whether the target is in view, how
much of it is unoccluded, and its size in pixels.

Any stage that scores a tracker asks the world for it (:meth:`humimic.world.world.World.
track_visibility`); the simulation then samples it at the camera frames, decimated to
``cameras.visibility_rate`` (each sample costs two segmentation renders per camera, at most
:data:`MAX_WIDTH` pixels wide). Per sample
and camera, two segmentation renders of the scene as it is at the frame's photon time:

* the whole scene (what the camera sees): ``visible_px``, the pixels of each target's geoms
  (:data:`humimic.world.names.TARGET_GEOMS`);
* the targets' geoms alone (nothing in front of them): ``full_px``, their whole silhouettes
  inside the image.

From these: ``in_view`` = some of the silhouette is inside the image (``full_px > 0``);
``unoccluded`` = ``visible_px / full_px`` (0 out of view), the share of the silhouette nothing
hides; ``size_px`` = the diameter of a disc of the visible area, ``2 sqrt(visible_px / pi)``.
A target is *visible* in a camera when it is in view and at least :data:`VISIBLE_FRACTION` of
it is unoccluded. The targets are drawn together in the second render, so a target hiding
another (a hand before the face) lowers both counts and is not counted as occlusion.

Frames between samples take the latest sample at or before them (:meth:`VisibilityArrays.at`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from humimic.world.names import HUMAN_PREFIX, TARGET_GEOMS

VISIBLE_FRACTION = 0.5
"""A target at least this unoccluded (and in view) is visible."""
MAX_WIDTH = 320
"""Wider cameras are rendered for visibility at a fraction of their resolution, this wide (the
counts scaled back; 640x480: 4x fewer pixels to draw and label)."""


def target_pixel_counts(seg: np.ndarray, geom_target: np.ndarray, n_targets: int
                        ) -> np.ndarray:
    """Pixels of each target in a segmentation render ``(H, W, 2)`` [object id, object type]:
    ``(n_targets,)``. ``geom_target[g]`` is the target index of geom ``g`` (-1: none)."""
    is_geom = seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
    ids = seg[..., 0][is_geom]
    ids = ids[(ids >= 0) & (ids < len(geom_target))]
    t = geom_target[ids]
    return np.bincount(t[t >= 0], minlength=n_targets)[:n_targets]


def unoccluded_fraction(visible_px: np.ndarray, full_px: np.ndarray) -> np.ndarray:
    """``visible_px / full_px``, 0 where the target is out of view (``full_px == 0``), at most 1
    (rasterisation can differ by a pixel between the renders)."""
    visible_px, full_px = np.asarray(visible_px, float), np.asarray(full_px, float)
    frac = np.divide(visible_px, full_px, out=np.zeros_like(visible_px), where=full_px > 0)
    return np.minimum(frac, 1.0)


def size_px(visible_px: np.ndarray) -> np.ndarray:
    """Diameter (px) of a disc as large as the visible area."""
    return 2.0 * np.sqrt(np.asarray(visible_px, float) / np.pi)


@dataclass
class VisibilityArrays:
    """Samples ``(N,)`` x cameras ``C`` x targets ``T``."""

    cameras: list[str]
    targets: list[str]
    t: np.ndarray
    """(N,) photon times (s)."""
    visible_px: np.ndarray
    """(N, C, T) pixels of the target the camera sees (at the camera's resolution)."""
    full_px: np.ndarray
    """(N, C, T) pixels of its whole silhouette inside the image."""

    @property
    def in_view(self) -> np.ndarray:
        return self.full_px > 0

    @property
    def unoccluded(self) -> np.ndarray:
        return unoccluded_fraction(self.visible_px, self.full_px)

    @property
    def size_px(self) -> np.ndarray:
        return size_px(self.visible_px)

    @property
    def visible(self) -> np.ndarray:
        """(N, C, T) in view and at least :data:`VISIBLE_FRACTION` unoccluded."""
        return self.in_view & (self.unoccluded >= VISIBLE_FRACTION)

    def at(self, t: np.ndarray) -> np.ndarray:
        """Index of the latest sample at or before each time (the first sample before it)."""
        i = np.searchsorted(self.t, np.asarray(t, float) + 1e-9, side="right") - 1
        return np.clip(i, 0, max(len(self.t) - 1, 0))

    def camera(self, name: str) -> int:
        return self.cameras.index(name)

    def target(self, name: str) -> int:
        return self.targets.index(name)


@dataclass
class Visibility:
    """Samples visibility of :data:`TARGET_GEOMS` in the eye cameras of a world's rig."""

    rig: object
    cameras: list[str]
    rate: float
    """Samples per second (at most one per camera frame)."""
    targets: list[str] = field(default_factory=lambda: list(TARGET_GEOMS))
    rows: list[tuple[float, np.ndarray, np.ndarray]] = field(default_factory=list)
    _next_t: float = 0.0

    def __post_init__(self) -> None:
        width = max(self.rig.intrinsics(c).width for c in self.cameras) if self.cameras else 1
        self.scale = min(1.0, MAX_WIDTH / width)
        m = self.rig.scene.model
        self.geom_target = np.full(m.ngeom, -1, np.intp)
        for k, target in enumerate(self.targets):
            for geom in TARGET_GEOMS[target]:
                self.geom_target[m.geom(HUMAN_PREFIX + geom).id] = k
        self.geoms = np.flatnonzero(self.geom_target >= 0)

    def due(self, t: float) -> bool:
        return t + 1e-9 >= self._next_t

    def sample(self, t: float) -> None:
        """Render the cameras at the scene's current state (photon time ``t``) and record."""
        n = len(self.targets)
        visible = np.zeros((len(self.cameras), n), np.int64)
        full = np.zeros_like(visible)
        for c, cam in enumerate(self.cameras):
            visible[c] = self.rig.label_counts(cam, self.geom_target, n, scale=self.scale)
            full[c] = self.rig.label_counts(cam, self.geom_target, n, self.geoms, self.scale)
        self.rows.append((t, visible / self.scale**2, full / self.scale**2))
        self._next_t = t + 1.0 / self.rate

    def maybe_sample(self, t: float) -> bool:
        """Sample if one is due at this camera frame; True if it did."""
        if not self.due(t):
            return False
        self.sample(t)
        return True

    def arrays(self) -> VisibilityArrays:
        c, n = len(self.cameras), len(self.targets)
        if not self.rows:
            z = np.zeros((0, c, n))
            return VisibilityArrays(list(self.cameras), list(self.targets), np.zeros(0), z, z)
        t, vis, full = zip(*self.rows, strict=True)
        return VisibilityArrays(list(self.cameras), list(self.targets), np.array(t),
                                np.stack(vis), np.stack(full))
