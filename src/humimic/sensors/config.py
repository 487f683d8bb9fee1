"""Scenario sections for the sensors and the clock."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator, model_validator

from humimic.scenario.base import Section
from humimic.sensors.camera_model import corner_radius, max_invertible_radius
from humimic.world.names import EYE_HFOV_DEG

#: Image sizes a camera may have (width, height in pixels).
MIN_RESOLUTION, MAX_RESOLUTION = (16, 16), (1920, 1440)


def check_resolution(resolution: tuple[int, int]) -> tuple[int, int]:
    """``resolution``; ValueError unless it is within :data:`MIN_RESOLUTION` ..
    :data:`MAX_RESOLUTION` (a field validator: the error names the ``resolution`` key)."""
    (w, h), (w0, h0), (w1, h1) = resolution, MIN_RESOLUTION, MAX_RESOLUTION
    if not (w0 <= w <= w1 and h0 <= h <= h1):
        raise ValueError(f"must be within {w0}x{h0} .. {w1}x{h1} (width x height)")
    return resolution


def check_distortion(distortion: tuple[float, float], hfov_deg: float,
                     resolution: tuple[int, int]) -> None:
    """ValueError unless the radial distortion can be undistorted over the whole image (see
    :func:`~humimic.sensors.camera_model.max_invertible_radius`)."""
    k1, k2 = distortion
    r_corner = corner_radius(math.radians(hfov_deg), *resolution)
    r_max = max_invertible_radius(k1, k2)
    if r_max < r_corner:
        w, h = resolution
        raise ValueError(f"distortion [{k1:g}, {k2:g}] cannot be undistorted over a "
                         f"{hfov_deg:g} deg {w}x{h} image (it folds over at normalised radius "
                         f"{max(r_max, 0.0):.2f}, the corner is at {r_corner:.2f}); e.g. "
                         f"k1 >= -0.05 for the wide eyes, -0.15 for the head camera")


class CoveredWindow(Section):
    """A camera covered (black frames) from ``start`` to ``end`` (s)."""

    camera: Literal["left", "right", "both"] = "both"
    start: float = Field(ge=0.0)
    end: float = Field(gt=0.0)

    @model_validator(mode="after")
    def _check_order(self) -> CoveredWindow:
        if self.end <= self.start:
            raise ValueError(f"end ({self.end:g} s) must be after start ({self.start:g} s)")
        return self


class Cameras(Section):
    """The robot's eye cameras (both eyes: stereo)."""

    enabled: bool = True
    """Render the robot's eyes (a wearable scenario without robot vision turns them off)."""
    which: Literal["wide", "foveal", "both"] = "wide"
    """Wide: 100 deg horizontal field of view; foveal: 24 deg; both: each eye's wide and
    foveal cameras (the wide ones first: a stage that takes the first two gets the wide
    pair)."""
    eyes: Literal["stereo", "left", "right"] = "stereo"
    resolution: tuple[int, int] = (320, 240)
    """Width, height in pixels."""
    rate: float = Field(60.0, gt=0.0, le=240.0)
    """Frames per second (Hz)."""
    noise_std: float = Field(0.0, ge=0.0, le=50.0)
    """Gaussian pixel noise, standard deviation in 8-bit grey levels."""
    distortion: tuple[float, float] = (0.0, 0.0)
    """Radial distortion k1, k2 (OpenCV convention)."""
    latency: float = Field(0.0, ge=0.0, le=0.5)
    """Transfer latency (s) before a frame reaches perception."""
    drop_rate: float = Field(0.0, ge=0.0, lt=1.0)
    """Probability that a stereo frame is lost in transfer (never published); see
    :mod:`humimic.sensors.faults`."""
    freeze_rate: float = Field(0.0, ge=0.0, lt=1.0)
    """Probability, per camera and frame, that a camera delivers its previous image again
    (stale pixels under the new time stamp)."""
    covered: list[CoveredWindow] = Field(default_factory=list)
    """Time windows in which a camera's images are black, e.g.
    ``[{camera: left, start: 2.0, end: 3.0}]``."""
    visibility_rate: float = Field(5.0, ge=0.0, le=240.0)
    """Samples per second (Hz) of the visibility ground truth (in view, unoccluded fraction,
    size in pixels per camera and target; :mod:`humimic.sensors.visibility`), taken at camera
    frames when a stage scores against it; each sample costs two segmentation renders per
    camera. 0: none (no visibility scores)."""

    @field_validator("resolution")
    @classmethod
    def _check_resolution(cls, resolution: tuple[int, int]) -> tuple[int, int]:
        return check_resolution(resolution)

    @model_validator(mode="after")
    def _check_distortion(self) -> Cameras:
        kinds = ("wide", "foveal") if self.which == "both" else (self.which,)
        check_distortion(self.distortion, max(EYE_HFOV_DEG[k] for k in kinds), self.resolution)
        return self


class HeadCamera(Section):
    """The camera worn on the person's forehead; defaults as Sugiyama & Miura's (368 x 240 at
    30 Hz). Its frame is the paper's I (:mod:`humimic.world.frames`); its images carry the
    intrinsics (with distortion) but not its pose, which a wearable system must estimate."""

    enabled: bool = False
    resolution: tuple[int, int] = (368, 240)
    rate: float = Field(30.0, gt=0.0, le=240.0)
    hfov_deg: float = Field(70.0, gt=5.0, lt=170.0)
    """Horizontal field of view of the pinhole part (before distortion), degrees."""
    distortion: tuple[float, float] = (-0.15, 0.02)
    """Radial distortion k1, k2 (OpenCV convention, :mod:`humimic.sensors.camera_model`)."""
    noise_std: float = Field(0.0, ge=0.0, le=50.0)

    @field_validator("resolution")
    @classmethod
    def _check_resolution(cls, resolution: tuple[int, int]) -> tuple[int, int]:
        return check_resolution(resolution)

    @model_validator(mode="after")
    def _check_image(self) -> HeadCamera:
        check_distortion(self.distortion, self.hfov_deg, self.resolution)
        return self


class Inertial(Section):
    """An accelerometer + gyroscope. Noise as densities (Kalibr/IEEE convention):
    white noise sigma in unit/sqrt(Hz), bias random walk in unit/s/sqrt(Hz)."""

    enabled: bool = True
    rate: float = Field(180.0, gt=0.0, le=840.0)
    accel_noise_density: float = Field(2.0e-3, ge=0.0)
    """m/s^2/sqrt(Hz)."""
    accel_bias_walk: float = Field(3.0e-3, ge=0.0)
    """m/s^3/sqrt(Hz)."""
    gyro_noise_density: float = Field(1.7e-4, ge=0.0)
    """rad/s/sqrt(Hz)."""
    gyro_bias_walk: float = Field(2.0e-5, ge=0.0)
    """rad/s^2/sqrt(Hz)."""
    drop_rate: float = Field(0.0, ge=0.0, lt=1.0)
    """Probability that a sample is lost (never published); see :mod:`humimic.sensors.faults`."""


class HeadInertial(Inertial):
    """The head-worn orientation sensor (an InertiaCube3, Sugiyama & Miura Table I): specific
    force and angular rate as :class:`Inertial`, plus its orientation in the paper's frame W
    (yaw about W's vertical, then pitch, then roll; errors slowly varying, as a sensor whose
    gravity and magnetometer corrections bound them)."""

    orientation: bool = True
    """Also output the orientation (the sensor's frame in W)."""
    yaw_rms_deg: float = Field(1.0, ge=0.0, le=45.0)
    """RMS yaw error (Table I: 1 deg)."""
    tilt_rms_deg: float = Field(0.25, ge=0.0, le=45.0)
    """RMS pitch and roll error (Table I: 0.25 deg)."""
    resolution_deg: float = Field(0.03, ge=0.0, le=5.0)
    """White (sample-to-sample) part of the error, per axis (Table I: RMS resolution 0.03 deg);
    included in the RMS values above."""
    yaw_tau_s: float = Field(60.0, gt=0.0)
    """Correlation time of the yaw error (s): its slow drift."""
    tilt_tau_s: float = Field(5.0, gt=0.0)
    """Correlation time of the pitch and roll errors (s)."""

    @model_validator(mode="after")
    def _resolution_within_rms(self) -> HeadInertial:
        if self.resolution_deg > min(self.yaw_rms_deg, self.tilt_rms_deg):
            raise ValueError(f"resolution_deg {self.resolution_deg} must not exceed the RMS "
                             f"errors (yaw {self.yaw_rms_deg}, tilt {self.tilt_rms_deg})")
        return self


class WiiInertial(Inertial):
    """The Wii remote's accelerometer and Motion Plus gyroscope: 100 Hz, noisier than the
    head sensor. Its own class, so that setting one key keeps the other Wii defaults."""

    rate: float = Field(100.0, gt=0.0, le=840.0)
    accel_noise_density: float = Field(2.7e-3, ge=0.0)
    accel_bias_walk: float = Field(5.0e-3, ge=0.0)
    gyro_noise_density: float = Field(5.0e-4, ge=0.0)
    gyro_bias_walk: float = Field(5.0e-5, ge=0.0)


class Sensors(Section):
    imu: HeadInertial = Field(default_factory=HeadInertial)
    """The IMU on the person's forehead (at the head camera, axes of its frame I), 180 Hz."""
    wiimote: WiiInertial = Field(default_factory=WiiInertial)
    """The Wii remote's accelerometer and gyroscope (Motion Plus) in the person's right hand,
    100 Hz, axes of the remote's frame A."""
    head_camera: HeadCamera = Field(default_factory=HeadCamera)


class Timing(Section):
    physics_rate: float = Field(840.0, ge=100.0, le=5000.0)
    """Physics steps per second (Hz)."""
    servo_rate: float = Field(420.0, gt=0.0, le=5000.0)
    """Joint servo (control) rate (Hz); must divide the physics rate."""

    @model_validator(mode="after")
    def _check_ratio(self) -> Timing:
        ratio = self.physics_rate / self.servo_rate
        if abs(ratio - round(ratio)) > 1e-9 or ratio < 1:
            raise ValueError(
                f"servo_rate must divide physics_rate ({self.physics_rate:g} Hz), got "
                f"{self.servo_rate:g} Hz; e.g. {self.physics_rate / 2:g}")
        return self
