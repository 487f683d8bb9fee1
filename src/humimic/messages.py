"""The values that flow between stages (each wrapped in a :class:`~humimic.stamped.Stamped`).

Topics on the bus and what they carry:

=============  ==========================================  ===========================
topic          value                                       producer -> consumer
=============  ==========================================  ===========================
``frames``     ``dict[str, CameraImage]`` (eye cameras)    world -> perception
``headcam``    ``CameraImage`` (pose withheld: NaN)        world -> wearable stages
``imu``        :class:`InertialReading` (+ orientation)    world -> wearable stages
``wiimote``    :class:`InertialReading`                    world -> wearable stages
``measurements`` :class:`Measurements` (robot base frame)  perception -> filter
``estimates``  :class:`Estimates` (robot base frame)       filter / oracle -> control
=============  ==========================================  ===========================

Perception's positions are in the robot base frame (m), velocities m/s, accelerations m/s^2.
The wearable sensors' values are in their own frames (:mod:`humimic.world.frames`): the head
camera and head IMU in the paper's interface frame I (x left, y up, z optical axis; the image's
``CameraModel`` uses OpenCV's axes, ``p_cv = R_CV_I p_I``), the Wii remote in its frame A, the
head IMU's orientation in the paper's world frame W. The ``Stamped.t`` of a measurement or
estimate is the *photon* (sample) time of the frame or sample it came from.
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


@dataclass(frozen=True)
class InertialReading:
    """One sample of a worn inertial sensor (topics ``imu`` and ``wiimote``)."""

    accel: np.ndarray
    """(3,) specific force in the sensor frame (m/s^2): ``R^T (a - g)``, gravity included, so
    a sensor at rest reads +9.81 along its up axis."""
    gyro: np.ndarray
    """(3,) angular velocity in the sensor frame (rad/s)."""
    R_W_sensor: np.ndarray | None = None
    """(3, 3) measured orientation: the sensor frame in the paper's W (the head IMU, an
    InertiaCube3; its frame is I). ``None`` for a sensor without orientation output (the Wii
    remote). ``scipy.spatial.transform.Rotation.from_matrix`` gives a quaternion (xyzw)."""
