"""The values that flow between stages (each wrapped in a :class:`~humimic.stamped.Stamped`).

Topics on the bus and what they carry:

=============  ==========================================  ===========================
topic          value                                       producer -> consumer
=============  ==========================================  ===========================
``frames``     ``dict[str, CameraImage]`` (eye cameras)    world -> perception
``headcam``    ``CameraImage``                             world -> wearable stages
``imu``        ``(accel (3,), gyro (3,))`` sensor frame    world -> wearable stages
``wiimote``    ``(accel (3,), gyro (3,))`` sensor frame    world -> wearable stages
``measurements`` :class:`Measurements` (robot base frame)  perception -> filter
``estimates``  :class:`Estimates` (robot base frame)       filter / oracle -> control
=============  ==========================================  ===========================

All positions are in the robot base frame (m), velocities m/s, accelerations m/s^2. The
``Stamped.t`` of a measurement or estimate is the *photon* time of the frame it came from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Measurement:
    """One target's 3-D measurement from one stereo frame."""

    target: str
    p_base: np.ndarray
    """(3,) position in the robot base frame (m)."""
    R_base: np.ndarray
    """(3, 3) measurement covariance (m^2)."""
    uv: dict[str, np.ndarray] = field(default_factory=dict)
    """Image position (pixels) per camera name, when measured."""
    state: str = "tracking"
    """Tracker state of this target: ``searching`` / ``tracking`` / ``lost``."""


@dataclass(frozen=True)
class Measurements:
    """Everything perception extracted from one frame set. Missing targets: not measured."""

    targets: dict[str, Measurement]
    states: dict[str, str] = field(default_factory=dict)
    """Tracker state per requested target, measured or not."""


@dataclass(frozen=True)
class TargetEstimate:
    """Filtered state of one target at the message's time stamp."""

    target: str
    p_base: np.ndarray
    v_base: np.ndarray
    a_base: np.ndarray
    P: np.ndarray | None = None
    """(9, 9) covariance of (p, v, a), when the estimator has one. Predict ahead with
    :func:`humimic.maths.kinematics.ca_predict`."""


@dataclass(frozen=True)
class Estimates:
    targets: dict[str, TargetEstimate]
