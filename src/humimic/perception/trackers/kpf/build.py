"""Build a ``kpf`` tracker stage from its scenario config."""

from __future__ import annotations

from humimic.perception.trackers.common import check_camera, skin_model_lut
from humimic.perception.trackers.kpf.stage import KpfStage


def kpf_stage(name: str, cfg, scenario, world, rngs, rlog) -> list:
    camera = check_camera(scenario, world, name, cfg.camera)
    lut = skin_model_lut(scenario, world, [camera], f"trackers.{name}")
    return [KpfStage(name, cfg, camera, world, lut, rngs[f"trackers.{name}"], rlog,
                     scenario.cameras.rate)]
