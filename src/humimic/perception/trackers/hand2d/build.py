"""Build a hand2d stage from its scenario section (cross-section checks: exit 2 naming the
key)."""

from __future__ import annotations

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.faces.detect import FaceDetector
from humimic.perception.trackers.common import check_camera
from humimic.perception.trackers.hand2d.stage import Hand2DStage
from humimic.perception.trackers.hand2d.tracker import Hand2DTracker
from humimic.scenario.errors import ScenarioError


def hand2d_stage(name, cfg, scenario, world, rngs, rlog) -> Hand2DStage:
    camera = check_camera(scenario, world, name, cfg.camera)
    if cfg.alpha + cfg.beta > 1.0:
        raise ScenarioError(f"scenario {scenario.name!r}", f"trackers.{name}.beta",
                            "alpha + beta must not exceed 1", cfg.beta,
                            f"at most {1.0 - cfg.alpha:g}")
    try:
        lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))
    except (OSError, ValueError) as err:
        raise ScenarioError(f"scenario {scenario.name!r}", f"trackers.{name}",
                            f"the skin colour model cannot be read: {err}") from None
    width, height = scenario.cameras.resolution
    tracker = Hand2DTracker(cfg, lut, width, height, rngs[f"trackers.{name}"],
                            FaceDetector())
    return Hand2DStage(name, cfg, camera, tracker, world.gt, rlog)
