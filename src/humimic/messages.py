"""The values that flow between stages (each wrapped in a :class:`~humimic.stamped.Stamped`).

Topics on the bus and what they carry:

=============  ==========================================  ===========================
topic          value                                       producer -> consumer
=============  ==========================================  ===========================
``frames``     ``dict[str, CameraImage]`` (eye cameras)    world -> perception
``headcam``    ``CameraImage`` (pose withheld: NaN)        world -> wearable stages
``imu``        :class:`InertialReading` (+ orientation)    world -> wearable stages
``wiimote``    :class:`InertialReading`                    world -> wearable stages
``head_pose``  :class:`HeadPose` (paper's W, frame I)      slam -> arm EKF, commands
``arm_pose``   :class:`ArmPose` (frame I, remote frame A)  arm EKF -> commands
``commands``   :class:`RobotCommand`                       commands -> robot follower
``measurements`` :class:`Measurements` (robot base frame)  perception -> filter
``estimates``  :class:`Estimates` (robot base frame)       filter / oracle -> control
``poses``      :class:`PoseEstimate` (robot base frame)    gest, tbp, kpf -> mimic, metrics
``tracks2d``   :class:`Tracks2D` (image px, one camera)    2-D trackers -> report
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


@dataclass(frozen=True)
class HeadPose:
    """The wearer's head (interface frame I) in the paper's frame W, as the SLAM estimates it
    (topic ``head_pose``, Sugiyama & Miura sec. III). Published after every IMU sample and every
    head-camera frame, stamped with that sample's or frame's time."""

    p_W: np.ndarray
    """(3,) position of I's origin (the head camera's optical centre) in W (m)."""
    q_W_I: np.ndarray
    """(4,) orientation ``[w, x, y, z]``: ``v_W = R(q) v_I``."""
    v_W: np.ndarray
    """(3,) velocity in W (m/s)."""
    w_I: np.ndarray
    """(3,) angular velocity in I (rad/s)."""
    a_W: np.ndarray
    """(3,) acceleration in W, gravity excluded (m/s^2)."""
    P: np.ndarray
    """(19, 19) covariance of the interface state (p, q, v, w, a, b)."""
    map_size: int = 0
    """Features in the map."""
    measured: int = -1
    """Features measured in this frame (-1 for an IMU sample)."""

    @property
    def R_W_I(self) -> np.ndarray:
        from humimic.motion import quat

        return quat.to_matrix(self.q_W_I)


@dataclass(frozen=True)
class ArmPose:
    """The Wii remote in the head frame I, as the arm EKF estimates it (topic ``arm_pose``,
    Sugiyama & Miura sec. IV). Published after every head-camera frame, stamped with its time."""

    p_I: np.ndarray
    """(3,) centre of the remote's marker in I (m)."""
    q_I_A: np.ndarray
    """(4,) orientation ``[w, x, y, z]`` of the remote's frame A in I: ``v_I = R(q) v_A``."""
    v_I: np.ndarray
    """(3,) velocity in I (m/s)."""
    w_A: np.ndarray
    """(3,) angular velocity relative to the head, in A (rad/s)."""
    P: np.ndarray
    """(19, 19) covariance of the state (p, q, v, w, a, b)."""
    measured: bool
    """The marker was seen and taken in this frame."""


@dataclass(frozen=True)
class RobotCommand:
    """One command to the robot (topic ``commands``, Sugiyama & Miura sec. V-C)."""

    kind: str
    """``move`` (the mobile base), ``head`` (pan and tilt) or ``arm`` (the right hand)."""
    target: np.ndarray
    """``move``: (x, y) of the base in the robot's start frame R (m; x forward, y left);
    ``head``: (pan, tilt) (rad; pan to the left, tilt down); ``arm``: (x, y, z) of the right
    palm in the robot's base frame (m; x forward, y left, z up)."""
    issued_t: float
    """When it went out (s)."""
    seq: int
    """Its number among the commands of its kind (0, 1, ...)."""


@dataclass(frozen=True)
class PoseEstimate:
    """One articulated (or free-part) pose estimate of one tracker (topic ``poses``), stamped
    with the photon time of the frame it came from."""

    tracker: str
    """The tracker's name (its key under ``trackers:``)."""
    kind: str
    """The tracker's kind (``gest``, ``tbp``, ``kpf``)."""
    state: np.ndarray
    """(d,) the MMSE estimate of the tracker's own state vector (``state_names``)."""
    state_names: tuple[str, ...]
    cov: np.ndarray | None = None
    """(d, d) weighted particle covariance of the state (the particles' spread)."""
    joints: dict[str, np.ndarray] = field(default_factory=dict)
    """Joint / part positions in the robot base frame (m) by name (``r_elbow``, ``r_wrist``,
    ``r_hand`` ... as :data:`humimic.bodymodel.kinematics.JOINT_SEGMENT`)."""
    angles: dict[str, float] = field(default_factory=dict)
    """Arm joint angles (rad, DB's convention ``R_SFE`` ... ``L_EB``) where estimated."""
    status: str = "tracking"
    """``tracking``, ``searching`` (no target yet or re-initialising) or ``lost``."""


TRACK_STATES = ("init", "tracking", "lost")
"""States of an image-space track: ``init`` (waiting for the detectors to agree), ``tracking``
and ``lost`` (the target's likelihood collapsed; the tracker re-initialises)."""


@dataclass(frozen=True)
class Track2D:
    """One image-space track (Menezes sec. 5): the MMSE state of a particle filter."""

    target: str
    """What is tracked: a human target (``right_hand``) or a person (``person``)."""
    u: float
    """Centre, pixels (OpenCV: u right, v down)."""
    v: float
    scale: float
    """The target's size in pixels (hand width, head width)."""
    angle: float = 0.0
    """In-plane rotation (rad, clockwise on the image)."""
    state: str = "tracking"
    """One of :data:`TRACK_STATES`."""
    identity: str = ""
    """Who the tracker believes it follows (a face identity), '' when unknown."""
    confidence: float = float("nan")
    """Recognition probability of ``identity`` (NaN without recognition)."""
    spread_px: float = float("nan")
    """Particle spread: sqrt of the trace of the (u, v) covariance (px)."""


@dataclass(frozen=True)
class Tracks2D:
    """A tracker's tracks in one camera frame (topic ``tracks2d``)."""

    tracker: str
    """The tracker's name (its key under the scenario's ``trackers:``)."""
    camera: str
    tracks: tuple[Track2D, ...]
    state: str = ""
    """The tracker's own state (e.g. the ICU state machine's, Menezes Fig. 15)."""
