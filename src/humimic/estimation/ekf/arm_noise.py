"""The arm EKF's measurement noise from the configured sensors (``arm.noise.source: sensors``).

The paper's values (Sugiyama & Miura sec. IV-B: centroid 10/3 px, area 0.3 of the measured
area, gyro 0.01 rad/s, pitch and roll 0.5 deg; ``source: paper``) are those of their real
camera and remote. On the simulated sensors the marker's are 7-13x too large: the filter's
position covariance came out ~30x the error's (position NEES 0.05-0.16 against 3 on
``sugiyama_fig3_arm_forward``, ``sugiyama_arm_mask``, ``sugiyama_fig10_robot_control``), and
trusting the area so little doubled the position RMSE.

* Marker centroid and area (:data:`CENTROID_PX`, :data:`AREA_REL`): not a property of one
  sensor setting but of the region extraction on the rendered image (the region's edge, the
  sphere's silhouette centroid ~0.2 px outside the centre's projection, the image noise);
  measured against the true marker centre on those scenarios (seeds 0-1, head camera 368x240,
  70 deg, ``noise_std`` 2, marker sphere of 2 cm at 0.3-0.6 m): centroid 0.16-0.45 px RMS per
  axis, area 3.3-6 % RMS (2.4 % of it a bias: the region misses part of its edge pixels).
* Gyro (:func:`gyro_std`): the relative rate is the remote's gyro minus the head's rate, each
  with its sensor's white noise (``density sqrt(rate)``).
* Pitch and roll (:func:`pitch_roll_std`): the accelerometer's white noise over g; the
  dynamic acceleration the static gate lets through (``|a - g| <= tol g`` turns the measured
  down by up to ``tol`` rad; uniform in that ball, ``tol / sqrt(5)`` rad RMS per axis, a bound:
  samples near rest sit nearer the centre); and the error of the head's tilt, which carries
  gravity into I (the head IMU's ``tilt_rms_deg`` with ``head_pose: slam``, none with the
  oracle). Measured on the scenarios above: 0.23-0.65 deg RMS; derived 0.59 (slam).
"""

from __future__ import annotations

import math

from humimic.estimation.ekf.arm import ArmNoise
from humimic.estimation.ekf.sensor_noise import white_std

#: sigma of the marker centroid (px) on the simulated head camera (module docstring).
CENTROID_PX = 0.35
#: sigma of the marker area as a fraction of the measured area (module docstring).
AREA_REL = 0.035


def gyro_std(wii, head_imu=None) -> float:
    """sigma (rad/s) of the remote's rate relative to the head: the Wii gyro's white noise
    and, when the head's rate is estimated (``head_imu``, a ``sensors.config.Inertial``), the
    head gyro's."""
    var = white_std(wii.gyro_noise_density, wii.rate) ** 2
    if head_imu is not None:
        var += white_std(head_imu.gyro_noise_density, head_imu.rate) ** 2
    return math.sqrt(var)


def pitch_roll_std(wii, static_tol_g: float, gravity: float, head_tilt: float = 0.0) -> float:
    """sigma (rad) of the accelerometer's pitch and roll: its white noise over ``gravity``
    (m/s^2), the static gate's ``static_tol_g / sqrt(5)`` and the head's tilt error
    ``head_tilt`` (rad), independent."""
    white = white_std(wii.accel_noise_density, wii.rate) / gravity
    return math.sqrt(white**2 + (static_tol_g / math.sqrt(5.0)) ** 2 + head_tilt**2)


def sensor_noise(sensors, head_pose: str, static_tol_g: float, gravity: float) -> ArmNoise:
    """The arm EKF's :class:`~humimic.estimation.ekf.arm.ArmNoise` for the configured
    ``sensors`` (a ``sensors.config.Sensors``), the head pose from ``slam`` or the ``oracle``."""
    head_imu = sensors.imu if head_pose == "slam" else None
    tilt = math.radians(head_imu.tilt_rms_deg) if head_imu is not None else 0.0
    return ArmNoise(centroid_px=CENTROID_PX, area_rel=AREA_REL,
                    gyro=gyro_std(sensors.wiimote, head_imu),
                    pitch_roll=pitch_roll_std(sensors.wiimote, static_tol_g, gravity, tilt))
