"""Build a GEST stage: cross-section checks, the skin colour model."""

from __future__ import annotations

from humimic.perception.trackers.common import check_cameras, skin_model_lut
from humimic.perception.trackers.gest.stage import GestStage


def gest_stage(name, cfg, scenario, world, rngs, rlog) -> GestStage:
    cams = check_cameras(scenario, world, name, cfg.cameras, 2)
    foveal = (None if cfg.foveal is None else
              check_cameras(scenario, world, name, cfg.foveal, 2, key="foveal"))
    lut = skin_model_lut(scenario, world, list(cams), f"trackers.{name}", gains=cfg.skin_gains)
    return GestStage(name, cfg, cams, lut, world, rngs[f"trackers.{name}"], rlog, foveal)
