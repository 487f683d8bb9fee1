"""Build a ``kpf`` tracker stage from its scenario config."""

from __future__ import annotations

from humimic.errors import closest
from humimic.perception.trackers.common import check_camera, skin_model_lut
from humimic.perception.trackers.kpf.stage import KpfStage
from humimic.scenario.errors import ScenarioError


def kpf_stage(name: str, cfg, scenario, world, rngs, rlog) -> list:
    camera = check_camera(scenario, world, name, cfg.camera)
    cams = [camera]
    if cfg.fovea is not None:
        if cfg.fovea.camera not in world.eye_cameras:
            raise ScenarioError(f"scenario {scenario.name!r}", f"trackers.{name}.fovea.camera",
                                "camera is not rendered by this scenario", cfg.fovea.camera,
                                f"{', '.join(world.eye_cameras)} (set cameras.which: both)",
                                closest(cfg.fovea.camera, world.eye_cameras))
        cams.append(cfg.fovea.camera)
    lut = skin_model_lut(scenario, world, cams, f"trackers.{name}")
    return [KpfStage(name, cfg, camera, world, lut, rngs[f"trackers.{name}"], rlog,
                     scenario.cameras.rate)]
