"""Build a TBP stage: cross-section checks, the body model, the skin colour model."""

from __future__ import annotations

from humimic.bodymodel.dimensions import avatar_body
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.common import check_cameras
from humimic.perception.trackers.tbp.stage import TbpStage
from humimic.scenario.errors import ScenarioError
from humimic.world.names import HUMAN_PREFIX


def tbp_stage(name, cfg, scenario, world, rngs, rlog) -> TbpStage:
    where = f"scenario {scenario.name!r}"
    cams = check_cameras(scenario, world, name,
                         None if cfg.camera is None else [cfg.camera], 1)
    if cfg.torso == "head":
        perc = getattr(scenario, "perception", None)
        if perc is None or "head" not in perc.targets:
            raise ScenarioError(where, f"trackers.{name}.torso",
                                "torso: head needs perception measuring the head "
                                "(perception.targets with head)", cfg.torso,
                                "truth (an oracle), or add perception: {targets: [head]}")
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    body = avatar_body(world.scene.model, HUMAN_PREFIX, torso="cylinder")
    return TbpStage(name, cfg, cams[0], body, lut, world, rngs[f"trackers.{name}"])
