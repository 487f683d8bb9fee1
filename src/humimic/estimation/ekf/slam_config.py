"""The scenario's ``slam`` section: Sugiyama & Miura's movement EKF SLAM (sec. III).

Example::

    slam:
      mode: fusion            # fusion | camera | inertial (Fig. 8's three ways)
      target_features: 20     # add new features while fewer are in view
      mask_arm: true          # never detect or match on the wearer's own arm

Units: m, s; pixel noise in pixels; angles in degrees where a key says ``_deg``. The noise
defaults are the paper's (sec. III-A/B) except the orientation sensor's, see
``orientation_std_deg``.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from humimic.estimation.ekf import motion_model as mm
from humimic.scenario.base import Section


class SlamNoise(Section):
    """Noise of the motion and measurement models."""

    jerk: float = Field(mm.SIGMA_JERK, gt=0.0, le=1e4)
    """sigma of the translational jerk (m/s^3), Sugiyama sec. III-A: 15."""
    angular_acc: float = Field(mm.SIGMA_ALPHA, gt=0.0, le=1e4)
    """sigma of the angular acceleration (rad/s^2): 15."""
    accel_bias_drift: Annotated[float, Field(ge=0.0, le=10.0)] | Literal["sensor"] = "sensor"
    """sigma of the accelerometer-bias variation per step (m/s^3; the paper: 1e-3). ``sensor``:
    from the head IMU's noise model, per W axis: its bias random walk and, horizontally, the
    drift of gravity turned by the slow tilt error
    (:func:`~humimic.estimation.ekf.sensor_noise.accel_bias_drift_W`)."""
    sigma_accel: Annotated[float, Field(gt=0.0, le=100.0)] | Literal["sensor"] = "sensor"
    """sigma of the acceleration measurement (m/s^2), eq. 7 (the paper: 0.5). ``sensor``: from
    the head IMU's noise model (``sensors.imu``), per W axis: the accelerometer's white noise,
    plus on the horizontal axes gravity times the orientation's white-equivalent tilt error
    (the measured orientation rotates the specific force into W)
    (:func:`~humimic.estimation.ekf.sensor_noise.accel_std_W`)."""
    orientation_std_deg: tuple[float, float] | Literal["sensor"] | None = "sensor"
    """sigma of the measured orientation's tilt (pitch, roll) and yaw (deg), as small rotations
    about W's axes, per sample. The InertiaCube3's errors (Table I: 0.25 deg tilt, 1 deg yaw
    RMS) vary slowly (seconds to a minute), so as white noise at 180 Hz they must count for far
    less than their RMS. ``sensor`` (default): the white noise with the same low-frequency
    power as the head IMU's configured Gauss-Markov errors, ``σ sqrt(2 τ rate)`` (10.5 deg tilt
    and 147 deg yaw for the defaults, :mod:`~humimic.estimation.ekf.sensor_noise`); fused as
    the former (1, 10) deg the filter followed the slow tilt error and was over-confident
    (position NEES 5-90 on the Fig. 8 jump, a 4.7 cm height offset on seed 5). ``null``: the
    paper's 1e-3 per quaternion component."""
    sigma_gyro: float = Field(0.01, gt=0.0, le=10.0)
    """sigma of the angular rate (rad/s) when ``use_gyro``: the arm EKF's eq. 15 value."""
    sigma_px: float = Field(2.0, gt=0.0, le=20.0)
    """sigma of a feature's image position (px), per frame, as white noise (the paper's eq. 8:
    1). The matches' errors are small but not white: the screen corners on the Fig. 8 jump
    (seed 7, against their true projections) are off by a constant 0.08 px (u) and 0.16 px
    (v) each while the head stands still -- the sub-pixel peak's bias, the same from frame to
    frame for the same view -- plus 0.2 px that varies with the motion. Fused as 1 px white
    noise, 30 frames a second averaged that bias away in the filter's belief but not in fact
    (the start position's error stayed while its covariance shrank: position NEES 6-8). 2 px
    is the white equivalent of a ~0.2 px error correlated over ~2 s (``0.2 sqrt(2 * 2 * 30)``);
    measured: NEES 3.1-3.8 and equal or better accuracy on the Fig. 8 jump and the Table II
    walk."""


class SlamConfig(Section):
    """The wearer's head pose and a map of image features from the head camera and IMU."""

    mode: Literal["fusion", "camera", "inertial"] = "fusion"
    """``fusion``: camera and IMU (the paper's method); ``camera``: frames only (the filter
    predicts from frame to frame); ``inertial``: the IMU only (no map). Fig. 8 (a)-(c)."""
    use_orientation: bool = True
    """Fuse the IMU's orientation output (eq. 6)."""
    accel_frame: Literal["I", "W"] = "I"
    """Where the accelerometer's reading is compared with the state: ``I`` (default), in the
    sensor's own frame, ``h = R(q)^T (a + b - g)``, so gravity ties the estimated tilt to it;
    ``W``, the paper's eq. 7, rotated into W by the orientation sensor's reading (whose slow
    tilt error then turns gravity into a drifting horizontal acceleration)."""
    use_gyro: bool = True
    """Also fuse the IMU's angular rate (``h = ω``, as the arm EKF's eq. 15; the paper's head
    filter uses only orientation and acceleration). The orientation sensor's error is slowly
    varying, so its absolute yaw cannot be trusted, but its rate is exact to a few mrad/s:
    with it the heading holds while the camera resolves the position (ATE on the Table II walk
    2.0 cm instead of 4.0 cm)."""
    target_features: int = Field(20, ge=0, le=200)
    """Initialise new features while fewer than this many are predicted in view."""
    max_map: int = Field(60, ge=4, le=400)
    """Most features held in the map (features long out of view are forgotten first)."""
    max_measured: int | None = Field(None, ge=1, le=400)
    """Search at most this many features per frame (the most uncertain); null: all in view."""
    mask_arm: bool = True
    """Keep features off the wearer's own arm and Wii remote (Sugiyama sec. V-B leaves this
    open): pixels of the red marker and the arm's colours below it are neither detected in
    nor matched (:mod:`humimic.estimation.ekf.arm_mask`)."""
    noise: SlamNoise = Field(default_factory=SlamNoise)
    init_depth: float = Field(2.0, gt=0.1, le=100.0)
    """Depth a new feature is initialised at (m): ``rho0 = 1/init_depth`` (Civera)."""
    init_inverse_depth_std: float = Field(0.5, gt=0.0, le=10.0)
    """sigma of a new feature's inverse depth (1/m)."""
    init_position_std: float = Field(0.02, ge=0.0, le=1.0)
    """How well the wearer knows where they start (m): the filter starts from the true head
    position plus a seeded error of this sigma (the paper: at (0, -2.5), facing the screen)."""
    patch_px: int = Field(11, ge=5, le=41)
    """Side of a feature's square patch (px, odd)."""
    min_zncc: float = Field(0.8, gt=0.0, le=1.0)
    """Correlation a match must reach."""
    search_sigma: float = Field(3.0, gt=0.0, le=10.0)
    """Active search inside this many sigma of the predicted innovation."""
    max_search_px: int = Field(48, ge=4, le=400)
    """Half-size cap of a search window (px)."""
    latency: float = Field(0.0, ge=0.0, le=0.5)
    """Declared processing latency (s) added to each ``head_pose``'s ready time."""
