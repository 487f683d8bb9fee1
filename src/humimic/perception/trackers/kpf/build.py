"""Build a ``kpf`` tracker stage from its scenario config."""

from __future__ import annotations

from humimic.errors import closest
from humimic.perception.trackers.common import check_camera, skin_model_lut
from humimic.perception.trackers.kpf.stage import KpfStage
from humimic.scenario.errors import ScenarioError


def fovea_hint(camera: str, cameras) -> str:
    """What to set so the eye camera ``camera`` (``L_foveal``, ``R_foveal``) is rendered,
    given the scenario's ``cameras`` section."""
    need = []
    if cameras.which != "both":
        need.append("cameras.which: both")
    if cameras.eyes != "stereo" and not camera.startswith(cameras.eyes[0].upper()):
        need.append("cameras.eyes: stereo")
    return f" (set {', '.join(need)})" if need else ""


def kpf_stage(name: str, cfg, scenario, world, rngs, rlog) -> list:
    camera = check_camera(scenario, world, name, cfg.camera)
    cams = [camera]
    if cfg.fovea is not None:
        key = "camera" if cfg.fovea.cameras is None else "cameras"
        for i, cam in enumerate(cfg.fovea.names):
            if cam not in world.eye_cameras:
                at = "" if cfg.fovea.cameras is None else f".{i}"
                raise ScenarioError(f"scenario {scenario.name!r}",
                                    f"trackers.{name}.fovea.{key}{at}",
                                    "camera is not rendered by this scenario", cam,
                                    f"{', '.join(world.eye_cameras) or 'none'}"
                                    + fovea_hint(cam, scenario.cameras),
                                    closest(cam, world.eye_cameras))
            cams.append(cam)
    lut = skin_model_lut(scenario, world, cams, f"trackers.{name}")
    return [KpfStage(name, cfg, camera, world, lut, rngs[f"trackers.{name}"], rlog,
                     scenario.cameras.rate)]
