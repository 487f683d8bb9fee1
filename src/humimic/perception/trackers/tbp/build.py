"""Build a TBP stage: cross-section checks, the body model, the skin colour model."""

from __future__ import annotations

from humimic.bodymodel.dimensions import avatar_body
from humimic.perception.trackers.common import check_camera, skin_model_lut
from humimic.perception.trackers.tbp.stage import TbpStage
from humimic.scenario.errors import ScenarioError
from humimic.world.names import HUMAN_PREFIX


def tbp_stage(name, cfg, scenario, world, rngs, rlog) -> TbpStage:
    where = f"scenario {scenario.name!r}"
    camera = check_camera(scenario, world, name, cfg.camera)
    if cfg.torso == "head":
        perc = getattr(scenario, "perception", None)
        if perc is None or "head" not in perc.targets:
            raise ScenarioError(where, f"trackers.{name}.torso",
                                "torso: head needs perception measuring the head "
                                "(perception.targets with head)", cfg.torso,
                                "truth (an oracle), or add perception: {targets: [head]}")
    lut = skin_model_lut(scenario, world, [camera], f"trackers.{name}")
    try:
        limits = cfg.limits.to_limits()
    except ValueError as err:
        raise ScenarioError(where, f"trackers.{name}.limits", str(err)) from None
    body = avatar_body(world.scene.model, HUMAN_PREFIX, limits, torso="cylinder")
    return TbpStage(name, cfg, camera, body, lut, world, rngs[f"trackers.{name}"])
