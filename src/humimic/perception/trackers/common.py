"""What every tracker kind's builder needs: where a scenario error points, which eye camera a
tracker watches, and the scenario's learned skin colour model as a lookup table."""

from __future__ import annotations

from pathlib import Path

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.scenario.errors import ScenarioError


def where(scenario) -> str:
    return f"scenario {scenario.name!r}"


def tracker_camera(scenario, world, name: str, camera: str | None) -> str:
    """The eye camera tracker ``name`` watches (its ``camera`` or the first rendered one)."""
    if not world.eye_cameras:
        raise ScenarioError(where(scenario), f"trackers.{name}", "the tracker needs an eye "
                            "camera and none is rendered", None, "cameras.enabled: true")
    if camera is None:
        return world.eye_cameras[0]
    if camera not in world.eye_cameras:
        raise ScenarioError(where(scenario), f"trackers.{name}.camera", "camera not rendered "
                            "by this scenario", camera, ", ".join(world.eye_cameras))
    return camera


def skin_model_lut(scenario, key: str, bits: int = 6) -> ColorLUT:
    """The skin colour model perception uses (``perception.color_model``, default
    ``models/colors/skin.json``) as a :class:`ColorLUT`; ``key`` names the tracker in errors."""
    cfg = getattr(scenario, "perception", None)
    path = Path(cfg.color_model if cfg is not None and cfg.color_model else DEFAULT_COLOR_MODEL)
    try:
        return ColorLUT(load_color_model(path), bits)
    except (OSError, ValueError) as err:
        raise ScenarioError(where(scenario), key, f"skin colour model unreadable: {err}",
                            str(path), "a file written by humimic.perception.cues.learn_colors"
                            ) from None
