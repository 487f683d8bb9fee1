"""The SLAM filter's value types: a map feature's bookkeeping, the predicted features of a
frame (the search ellipses) and the filter's parameters (Sugiyama & Miura sec. III)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from humimic.estimation.ekf import motion_model as mm

POSE_COLS = np.arange(0, 7)


@dataclass
class MapFeature:
    """Bookkeeping of one map feature (its numbers live in the filter's state)."""

    fid: int
    dim: int
    """6 while inverse depth, 3 once XYZ."""
    offset: int = 0
    """First column of its block in the state."""
    known: bool = False
    """A prior known feature (never deleted or re-estimated)."""
    tries: int = 0
    hits: int = 0
    misses_in_row: int = 0


@dataclass
class FeaturePrediction:
    """Where the visible map features should appear in the next frame, and how sure we are."""

    fids: np.ndarray
    """(k,) feature ids, predicted inside the image and in front of the camera."""
    uv: np.ndarray
    """(k, 2) predicted undistorted pixels."""
    S: np.ndarray
    """(k, 2, 2) innovation covariance of each (px^2, measurement noise included)."""
    PHt: np.ndarray = field(repr=False)
    """(n, 2k) ``P H^T``, reused by the update."""
    S_full: np.ndarray = field(repr=False)
    """(2k, 2k) joint innovation covariance."""


@dataclass(frozen=True)
class SlamParams:
    """Noise and map parameters (Sugiyama sec. III; Civera et al. 2008 for the inverse depth)."""

    noise: mm.MotionNoise = mm.MotionNoise()
    sigma_orientation: float = mm.SIGMA_ORIENTATION
    """Per quaternion component (the paper's eq. 6 noise), used when
    ``orientation_tilt_yaw`` is None and along ``q`` itself otherwise."""
    orientation_tilt_yaw: tuple[float, float] | None = None
    """sigma (rad) of the measured orientation's error as small rotations about W's
    horizontal axes (tilt) and its vertical (yaw): the quaternion noise is
    ``J diag(tilt^2, yaw^2, tilt^2) J^T`` with ``J = d(q(δ) ⊗ q)/dδ`` (W's y is up)."""
    sigma_accel: float | tuple[float, float, float] = mm.SIGMA_ACCEL
    """m/s^2, one for every axis of W or one per axis (eq. 7)."""
    sigma_gyro: float = 0.01
    """rad/s, when the IMU's angular rate is fused (the arm EKF's eq. 15 value)."""
    sigma_px: float = 1.0
    rho0: float = 0.5
    """Initial inverse depth of a new feature (1/m)."""
    sigma_rho: float = 0.5
    """Its standard deviation (1/m): the 95 % region of ``rho0 ± 2 sigma`` spans 0.67 m to
    infinity."""
    margin_px: float = 4.0
    """A feature predicted closer than this to the image border is not predicted visible."""


#: The default parameters (a frozen value, safe to share).
DEFAULT_SLAM_PARAMS = SlamParams()
