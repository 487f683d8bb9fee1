"""Build an ICU stage from its scenario section (cross-section checks: exit 2 naming the key)."""

from __future__ import annotations

from humimic.perception.faces.detect import DetectorParams, FaceDetector
from humimic.perception.trackers.common import check_camera, skin_model_lut
from humimic.perception.trackers.icu.stage import IcuStage
from humimic.perception.trackers.icu.tracker import IcuTracker
from humimic.scenario.errors import ScenarioError
from humimic.world.faces import IDENTITY_NAMES


def icu_stage(name, cfg, scenario, world, rngs, rlog) -> IcuStage:
    where = f"scenario {scenario.name!r}"
    camera = check_camera(scenario, world, name, cfg.camera)
    identity = cfg.identity or scenario.human.identity
    if identity not in IDENTITY_NAMES:
        raise ScenarioError(where, f"trackers.{name}.identity", "unknown identity", identity,
                            ", ".join(IDENTITY_NAMES))
    if cfg.near is not None and (cfg.near.module == name
                                 or cfg.near.module not in (scenario.trackers or {})):
        raise ScenarioError(where, f"trackers.{name}.near.module",
                            "not another tracker of this scenario", cfg.near.module,
                            ", ".join(k for k in (scenario.trackers or {}) if k != name)
                            or "none")
    if cfg.alpha + cfg.beta > 1.0:
        raise ScenarioError(where, f"trackers.{name}.beta", "alpha + beta must not exceed 1",
                            cfg.beta, f"at most {1.0 - cfg.alpha:g}")
    params = DetectorParams(min_size=cfg.min_face_px, fit_px=cfg.face_fit_px)
    recogniser, tutor = None, 0
    if cfg.recognition:
        from humimic.perception.faces.training import RenderSpec, trained_model

        people = [p.identity for p in scenario.human.people]
        known = list(dict.fromkeys([identity, *people, *IDENTITY_NAMES]))[: cfg.enrolled]
        recogniser = trained_model(known, RenderSpec(per_identity=cfg.views), params)
    skin = None
    if cfg.search == "skin":
        skin = skin_model_lut(scenario, world, [camera], f"trackers.{name}.search")
    width, height = scenario.cameras.resolution
    tracker = IcuTracker(cfg, width, height, rngs[f"trackers.{name}"], FaceDetector(params),
                         recogniser, tutor, skin)
    fx = world.eye_rig.intrinsics(camera).fx if cfg.near is not None else None
    return IcuStage(name, cfg, camera, tracker, identity, world.gt, rlog,
                    getattr(world, "people", None),
                    getattr(world, "track_visibility", lambda: None)(), fx)
