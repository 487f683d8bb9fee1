"""Build a hand2d stage from its scenario section (cross-section checks: exit 2 naming the
key)."""

from __future__ import annotations

from humimic.perception.cues.auto_colors import BACKGROUND_RATIO
from humimic.perception.faces.detect import FaceDetector
from humimic.perception.trackers.common import check_camera, skin_model_lut
from humimic.perception.trackers.hand2d.stage import Hand2DStage
from humimic.perception.trackers.hand2d.tracker import Hand2DTracker
from humimic.scenario.errors import ScenarioError


def hand2d_stage(name, cfg, scenario, world, rngs, rlog) -> Hand2DStage:
    camera = check_camera(scenario, world, name, cfg.camera)
    if cfg.alpha + cfg.beta > 1.0:
        raise ScenarioError(f"scenario {scenario.name!r}", f"trackers.{name}.beta",
                            "alpha + beta must not exceed 1", cfg.beta,
                            f"at most {1.0 - cfg.alpha:g}")
    # the ratio cut (auto_colors.BACKGROUND_RATIO): lab_clutter's dark-brown posts are not a
    # dark skin (menezes_fig5_hand, seed 99, 3 s, skin [0.40, 0.27, 0.20]: without it 34 %
    # lost, centre RMSE 37 px)
    lut = skin_model_lut(scenario, world, [camera], f"trackers.{name}",
                         background_ratio=BACKGROUND_RATIO)
    width, height = scenario.cameras.resolution
    tracker = Hand2DTracker(cfg, lut, width, height, rngs[f"trackers.{name}"],
                            FaceDetector())
    return Hand2DStage(name, cfg, camera, tracker, world.gt, rlog,
                       getattr(world, "track_visibility", lambda: None)(),
                       getattr(world, "people", None))
