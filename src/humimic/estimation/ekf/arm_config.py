"""The scenario's ``arm`` section: Sugiyama & Miura's Wii-remote arm EKF (sec. IV).

Example::

    arm:
      head_pose: slam          # slam (the head_pose topic) | oracle (ground truth)
      pitch_roll: gravity      # gravity (exact) | paper (eq. 22's subtraction)
      marker: {select: predicted, hue_deg: [-10, 20]}

Needs the head camera, the Wii remote's inertial sensor and a visible remote
(``sensors.head_camera.enabled``, ``sensors.wiimote.enabled``, ``human.wiimote``); with
``head_pose: slam`` also the ``slam`` section. Units: m, s, rad; keys in degrees say ``_deg``.
The motion model's noise is the paper's (sec. III-A); the measurements' comes from the
configured sensors (``noise.source: sensors``, :mod:`.arm_noise`) or the paper's (``paper``).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Literal

from pydantic import Field, model_validator

from humimic.estimation.ekf import motion_model as mm
from humimic.estimation.ekf.arm import ArmNoise
from humimic.estimation.ekf.arm_marker import MarkerParams
from humimic.estimation.ekf.arm_model import G0
from humimic.estimation.ekf.arm_noise import sensor_noise
from humimic.scenario.base import Section

_N, _M = ArmNoise(), MarkerParams()


class ArmNoiseConfig(Section):
    """Noise of the arm EKF's models. The measurement sigmas left unset come from ``source``."""

    source: Literal["sensors", "paper"] = "sensors"
    """``sensors``: from the configured sensors (:mod:`.arm_noise`: gyro and pitch/roll from the
    Wii remote's and head IMU's noise densities, centroid 0.35 px and area 0.035 measured on the
    simulated head camera); ``paper``: Sugiyama sec. IV-B's 10/3 px, 0.3, 0.01 rad/s, 0.5 deg.
    Measured on sugiyama_fig3_arm_forward, sugiyama_arm_mask and sugiyama_fig10_robot_control,
    seeds 0-9: position NEES 1.8-2.9 with 89-99 % of frames in the 95 % band with ``sensors``
    (0.10-0.11, 11-14 % with ``paper``, the covariance ~30x too large); position RMSE 8.8 /
    17.8 / 4.1 mm against the paper's noise's 10.7 / 45.0 / 8.7 (the area trusted). The head's
    share assumes its IMU (``slam.mode`` fusion or inertial): with ``slam.mode: camera`` the
    head's tilt error is not modelled (sugiyama_fig3_arm_forward seed 0: orientation tilt RMSE
    2.9 deg against 0.40 with fusion, the same 2.9 with ``paper``; modelled 0.59 deg), so set
    ``pitch_roll_deg`` there."""
    jerk: float = Field(mm.SIGMA_JERK, gt=0.0, le=1e4)
    """sigma of the jerk (m/s^3): 15, as the movement model (eq. 10's correspondence)."""
    angular_acc: float = Field(mm.SIGMA_ALPHA, gt=0.0, le=1e4)
    """sigma of the angular acceleration (rad/s^2): 15."""
    centroid_px: float | None = Field(None, gt=0.0, le=100.0)
    """sigma of the marker's centroid (px; paper 10/3)."""
    area_rel: float | None = Field(None, gt=0.0, le=10.0)
    """sigma of the marker's area as a fraction of the measured area (paper 0.3)."""
    gyro: float | None = Field(None, gt=0.0, le=10.0)
    """sigma of the relative angular velocity (rad/s; paper 0.01)."""
    pitch_roll_deg: float | None = Field(None, gt=0.0, le=45.0)
    """sigma of the accelerometer's pitch and roll (deg; paper 0.5)."""


class MarkerConfig(Section):
    """Finding the marker in the head-camera image (:mod:`.arm_marker`)."""

    select: Literal["predicted", "largest"] = "predicted"
    """``largest``: the largest marker-coloured region (the paper); ``predicted``: the region
    the filter's prediction makes most likely (the largest plausible one to start)."""
    hue_deg: tuple[float, float] = _M.hue_deg
    """Hue band (deg); the paper's is 0-20, widened below 0 for a red that straddles 0/360."""
    min_saturation: float = Field(_M.min_saturation, ge=0.0, le=1.0)
    min_value: float = Field(_M.min_value, ge=0.0, le=1.0)
    min_pixels: int = Field(_M.min_pixels, ge=1, le=10000)
    min_fill: float = Field(_M.min_fill, ge=0.0, le=1.0)
    """Smallest fraction of its bounding box a region must fill (a disc: 0.79; 0 = off)."""
    max_aspect: float = Field(_M.max_aspect, ge=1.0)
    """Largest ratio of the bounding box's sides."""
    start_depth: tuple[float, float] = (0.15, 1.2)
    """Depths (m) at which a region's area may put the marker to start the filter: within
    arm's reach."""

    def params(self) -> MarkerParams:
        return MarkerParams(tuple(self.hue_deg), self.min_saturation, self.min_value,
                            self.min_pixels, self.min_fill, self.max_aspect)


class ArmConfig(Section):
    """The Wii remote's pose in the head frame I from its marker, gyro and accelerometer."""

    head_pose: Literal["slam", "oracle"] = "slam"
    """Where the head's orientation and rate come from: the ``slam`` stage's ``head_pose``
    topic, or the ground truth (``oracle``: the arm EKF's own errors alone)."""
    pitch_roll: Literal["gravity", "paper"] = "gravity"
    """``paper``: the head's pitch and roll subtracted from the accelerometer's (eq. 22, exact
    only for a level head); ``gravity``: the head's orientation carries gravity into I."""
    use_area: bool = True
    """Use the marker's area (eq. 13); without it the depth is unobserved."""
    static_tol_g: float = Field(0.02, gt=0.0, le=1.0)
    """Pitch and roll are measured while ``|a_wii^I - g^I| <=`` this (in g): the paper's 0.02."""
    noise: ArmNoiseConfig = Field(default_factory=ArmNoiseConfig)
    marker: MarkerConfig = Field(default_factory=MarkerConfig)
    gate_prob: float | None = Field(0.9999, gt=0.5, lt=1.0)
    """Chi-square gate of a marker measurement (null: none)."""
    max_gap: float = Field(0.25, gt=0.0, le=60.0)
    """Seconds without an accepted marker after which the next one restarts the position."""
    max_rejected: int = Field(3, ge=1, le=1000)
    """Gated-out markers in a row after which the next one restarts the position."""
    latency: float = Field(0.0, ge=0.0, le=0.5)
    """Declared processing latency (s) added to each ``arm_pose``'s ready time."""

    @model_validator(mode="after")
    def _band(self) -> ArmConfig:
        lo, hi = self.marker.start_depth
        if not 0.0 < lo < hi:
            raise ValueError(f"marker.start_depth must be 0 < near < far, got {lo}, {hi}")
        return self

    def arm_noise(self, sensors) -> ArmNoise:
        """The measurement noise: ``noise.source``'s, with the sigmas set in ``noise`` instead
        (``sensors``: the scenario's ``sensors`` section)."""
        n = self.noise
        base = (_N if n.source == "paper" else
                sensor_noise(sensors, self.head_pose, self.static_tol_g, G0))
        pr = None if n.pitch_roll_deg is None else math.radians(n.pitch_roll_deg)
        return replace(base, **{k: v for k, v in (
            ("centroid_px", n.centroid_px), ("area_rel", n.area_rel), ("gyro", n.gyro),
            ("pitch_roll", pr)) if v is not None})

    def motion_noise(self) -> mm.MotionNoise:
        return mm.MotionNoise(jerk=self.noise.jerk, alpha=self.noise.angular_acc)


def check_arm(scenario) -> None:
    """Cross-section checks of ``arm`` (raise :class:`ScenarioError`, exit status 2): the
    sensors it reads must be on, and ``head_pose: slam`` needs the ``slam`` section."""
    from humimic.scenario.errors import ScenarioError

    where = f"scenario {scenario.name!r}"
    needs = (("sensors.head_camera.enabled", scenario.sensors.head_camera.enabled,
              "the arm EKF measures the marker in the head camera's frames"),
             ("sensors.wiimote.enabled", scenario.sensors.wiimote.enabled,
              "the arm EKF reads the Wii remote's gyro and accelerometer"),
             ("human.wiimote", scenario.human.wiimote,
              "the arm EKF needs the Wii remote and its marker in the person's hand"))
    for key, on, why in needs:
        if not on:
            raise ScenarioError(where, key, f"must be true for the arm section: {why}", False,
                                "true, or remove the arm section")
    if scenario.arm.head_pose == "slam" and getattr(scenario, "slam", None) is None:
        raise ScenarioError(where, "arm.head_pose",
                            "slam needs the scenario's slam section (it publishes head_pose)",
                            "slam", "oracle, or add a slam section")
