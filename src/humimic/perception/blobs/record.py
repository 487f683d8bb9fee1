"""What the perception stage saw, frame by frame, for the scores and reproductions after a run.

A passive recorder: the stage appends one row per stereo frame; :meth:`PerceptionRecord.arrays`
stacks them. Nothing here is used by the pipeline itself.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from humimic.sensors.camera_model import CameraModel, Intrinsics
from humimic.spill import SpillRows

STATES = ("searching", "tracking", "lost")
STATE_CODE = {s: i for i, s in enumerate(STATES)}


@dataclass
class PerceptionArrays:
    """Stacked records: F frames, T targets (``targets`` order), eyes (left, right)."""

    targets: list[str]
    cameras: tuple[str, str]
    intrinsics: tuple[Intrinsics, Intrinsics]
    t: np.ndarray
    """(F,) photon times (s)."""
    T_base_cam: np.ndarray
    """(F, 2, 4, 4) eye poses at the photon times."""
    state: np.ndarray
    """(F, T) int: index into :data:`STATES`."""
    seen: np.ndarray
    """(F, T, 2) bool: a tracked blob in that eye carries the target's name."""
    confirmed: np.ndarray
    """(F, T) bool: the name was sure (identity margin) in that frame."""
    centre: np.ndarray
    """(F, T, 2, 2) blob centres (px), zeros where not seen."""
    cov: np.ndarray
    """(F, T, 2, 2, 2) blob shape covariances (px^2)."""
    ok: np.ndarray
    """(F, T) bool: a valid 3-D measurement."""
    reason: np.ndarray
    """(F, T) object: '' or why the stereo measurement failed ('not_seen' if no blob pair)."""
    p_base: np.ndarray
    """(F, T, 3) measured positions (m), zeros where not ok."""
    R_base: np.ndarray
    """(F, T, 3, 3) propagated covariances (m^2)."""
    uv_match: np.ndarray
    """(F, T, 2, 2) the stereo correspondence (left blob centre, right match) in px."""
    score: np.ndarray
    """(F, T) ZNCC of the match."""

    def index(self, target: str) -> int:
        return self.targets.index(target)

    def camera(self, frame: int, eye: int) -> CameraModel:
        """The eye's calibrated camera at frame ``frame``."""
        return CameraModel(self.cameras[eye], self.intrinsics[eye],
                           self.T_base_cam[frame, eye].copy())


@dataclass
class PerceptionRecord:
    targets: list[str]
    cameras: tuple[str, str]
    intrinsics: tuple[Intrinsics, Intrinsics] | None = None
    rows: SpillRows = field(default_factory=SpillRows)
    """One row per frame, batches on disk (memory flat in the run's duration)."""

    def append(self, t: float, T_base_cam: np.ndarray, state: np.ndarray, seen: np.ndarray,
               confirmed: np.ndarray, centre: np.ndarray, cov: np.ndarray, ok: np.ndarray,
               reason: list[str], p_base: np.ndarray, R_base: np.ndarray,
               uv_match: np.ndarray, score: np.ndarray) -> None:
        self.rows.append((t, T_base_cam, state, seen, confirmed, centre, cov, ok, reason, p_base,
                          R_base, uv_match, score))

    def __len__(self) -> int:
        return len(self.rows)

    def arrays(self, targets: list[str] | None = None) -> PerceptionArrays:
        """The stacked records; with ``targets``, of just those targets (their columns alone
        are gathered from the spilled rows, the rest never is)."""
        targets = list(self.targets if targets is None else targets)
        n = len(targets)
        if not self.rows:
            z = np.zeros
            return PerceptionArrays(targets, self.cameras, self.intrinsics, z(0),
                                    z((0, 2, 4, 4)), z((0, n), int), z((0, n, 2), bool),
                                    z((0, n), bool), z((0, n, 2, 2)), z((0, n, 2, 2, 2)),
                                    z((0, n), bool),
                                    np.empty((0, n), object), z((0, n, 3)), z((0, n, 3, 3)),
                                    z((0, n, 2, 2)), z((0, n)))
        idx = [self.targets.index(t) for t in targets]
        cols = self.rows.columns({j: (lambda c: c) if j < 2 else (lambda c: c[:, idx])
                                  for j in range(13)})
        reason = np.empty((len(self.rows), n), object)
        reason[:] = cols[8].tolist()
        arrays = [*cols[1:8], reason, *cols[9:]]
        return PerceptionArrays(targets, self.cameras, self.intrinsics,
                                cols[0].astype(float), *arrays)
