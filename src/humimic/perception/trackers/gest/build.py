"""Build a GEST stage: cross-section checks, the skin colour model."""

from __future__ import annotations

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.common import check_cameras
from humimic.perception.trackers.gest.stage import GestStage
from humimic.scenario.errors import ScenarioError


def gest_stage(name, cfg, scenario, world, rngs, rlog) -> GestStage:
    cams = check_cameras(scenario, world, name, cfg.cameras, 2)
    if not DEFAULT_COLOR_MODEL.is_file():
        raise ScenarioError(f"scenario {scenario.name!r}", f"trackers.{name}",
                            "skin colour model not found", str(DEFAULT_COLOR_MODEL))
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    return GestStage(name, cfg, cams, lut, world, rngs[f"trackers.{name}"], rlog)
