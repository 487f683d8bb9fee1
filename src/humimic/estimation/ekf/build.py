"""Build the SLAM stage from a scenario, checking it has the sensors it needs.

A missing sensor is a bad scenario (:class:`~humimic.scenario.errors.ScenarioError`, one line,
exit status 2) naming the key to change: the camera modes need ``sensors.head_camera``, the
inertial modes ``sensors.imu`` (with its orientation output unless ``slam.use_orientation`` is
off).
"""

from __future__ import annotations

from humimic.estimation.ekf.arm_mask import ArmMaskParams
from humimic.estimation.ekf.slam_stage import SlamStage
from humimic.scenario.errors import ScenarioError


def check_slam(scenario) -> None:
    cfg, where = scenario.slam, f"scenario {scenario.name!r}"
    sensors = scenario.sensors
    if cfg.mode != "inertial" and not sensors.head_camera.enabled:
        raise ScenarioError(where, "sensors.head_camera.enabled",
                            f"slam (mode {cfg.mode}) needs the head camera", False,
                            "true, or slam.mode: inertial")
    if cfg.mode != "camera":
        if not sensors.imu.enabled:
            raise ScenarioError(where, "sensors.imu.enabled",
                                f"slam (mode {cfg.mode}) needs the head IMU", False,
                                "true, or slam.mode: camera")
        if cfg.use_orientation and not sensors.imu.orientation:
            raise ScenarioError(where, "sensors.imu.orientation",
                                "slam.use_orientation needs the IMU's orientation output",
                                False, "true, or slam.use_orientation: false")


def mask_params(scenario) -> ArmMaskParams:
    """The arm mask for the scenario's wearer: their skin and sleeve colours."""
    h = scenario.human
    return ArmMaskParams(body_rgb=(tuple(h.skin), tuple(h.shirt)))


def slam_stages(scenario, world, rngs, rlog) -> list:
    check_slam(scenario)
    return [SlamStage(scenario.slam, world, rngs["slam"], rlog, mask_params(scenario),
                      image_every=scenario.output.image_every)]
