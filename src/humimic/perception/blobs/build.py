"""Build the perception, filter and tracking-report stages from a scenario.

Cross-section checks raise :class:`~humimic.scenario.errors.ScenarioError` (one line, exit
status 2): perception needs both eyes, named cameras must be rendered, colour-model files must
be readable (or the skin in view, to learn it: ``auto``), a filter needs perception.
"""

from __future__ import annotations

from pathlib import Path

from humimic.estimation.stage import FilterRecord, FilterStage
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL, TRACKABLE_TARGETS
from humimic.perception.blobs.record import PerceptionRecord
from humimic.perception.blobs.report import TrackingReport
from humimic.perception.blobs.stage import PerceptionStage
from humimic.perception.cues.auto_colors import NotInView, file_lut, learned_lut
from humimic.perception.cues.color_models import ColorLUT
from humimic.pipeline.stage import Stage
from humimic.scenario.errors import ScenarioError


def _where(scenario) -> str:
    return f"scenario {scenario.name!r}"


def check_perception(scenario, world) -> tuple[str, str]:
    """Cross-section checks; returns the (left, right) camera names perception uses."""
    cfg, where = scenario.perception, _where(scenario)
    if cfg is None:
        raise ScenarioError(where, "filter", "the filter needs a perception section (it "
                            "filters perception's measurements)", None, "add perception: {}")
    if scenario.cameras.eyes != "stereo":
        raise ScenarioError(where, "cameras.eyes", "perception triangulates: it needs both "
                            "eyes", scenario.cameras.eyes, "stereo")
    cams = tuple(cfg.cameras) if cfg.cameras is not None else tuple(world.eye_cameras[:2])
    for key, cam in zip(("perception.cameras.0", "perception.cameras.1"), cams, strict=True):
        if cam not in world.eye_cameras:
            raise ScenarioError(where, key, f"camera {cam!r} is not rendered by this scenario",
                                cam, f"{', '.join(world.eye_cameras)} (set cameras.which)")
    return cams


def _color_key(cfg, target: str) -> str:
    for i, c in enumerate(cfg.colors):
        if c.target == target:
            return f"perception.colors.{i}.file"
    return "perception.color_model"


def _source(cfg, target: str) -> Path | str:
    f = cfg.color_file(target)
    return "auto" if f == "auto" else Path(f).resolve()


def load_luts(scenario, world, cams) -> dict[str, ColorLUT]:
    """One :class:`ColorLUT` per tracked target (published first, then distractors); targets
    with the same colour model (file, or ``auto``: learned for this world's person as seen by
    ``cams``, :mod:`humimic.perception.cues.auto_colors`, its bins cleared where the scene's
    other pixels outnumber the skin's ``background_odds`` times) share one LUT object."""
    cfg, where = scenario.perception, _where(scenario)
    targets = list(cfg.targets)
    if cfg.identify_all:
        sources = {_source(cfg, t) for t in targets}
        targets += [t for t in TRACKABLE_TARGETS
                    if t not in targets and _source(cfg, t) in sources]
    by_source: dict[Path | str, ColorLUT] = {}
    out = {}
    for target in targets:
        source = _source(cfg, target)
        if source not in by_source:
            key = _color_key(cfg, target)
            if source == "auto":
                try:
                    by_source[source] = learned_lut(world, list(cams), "skin", "rgb",
                                                    cfg.lut_bits,
                                                    background_odds=cfg.background_odds).lut
                except NotInView as err:
                    raise ScenarioError(where, key, f"cannot learn the skin colours: {err}",
                                        "auto", f"a colour-model file, e.g. "
                                        f"{DEFAULT_COLOR_MODEL}") from None
                out[target] = by_source[source]
                continue
            if not source.is_file():
                hint = ("learn one: python -m humimic.perception.cues.learn_colors --out "
                        f"{DEFAULT_COLOR_MODEL}") if source == DEFAULT_COLOR_MODEL.resolve() \
                    else "an existing colour-model file"
                raise ScenarioError(where, key, "colour-model file not found", str(source),
                                    hint)
            try:
                by_source[source] = file_lut(source, cfg.lut_bits).lut
            except ValueError as err:
                raise ScenarioError(
                    where, key, str(err), str(source),
                    "a file written by humimic.perception.cues.learn_colors") from None
        out[target] = by_source[source]
    return out


def perception_stages(scenario, world, rngs, rlog) -> list[Stage]:
    """Perception, filter (when configured) and the tracking report, in pipeline order."""
    cams = check_perception(scenario, world)
    cfg = scenario.perception
    luts = load_luts(scenario, world, cams)
    prec = PerceptionRecord(list(luts), cams)
    period = 1.0 / scenario.cameras.rate
    latency = period if cfg.latency is None else cfg.latency
    stages: list[Stage] = [PerceptionStage(cfg, cams, luts, rngs["perception"], prec, rlog,
                                           latency, period, scenario.duration,
                                           skip_repeats=scenario.cameras.noise_std > 0.0)]
    frec = None
    if scenario.filter is not None:
        frec = FilterRecord(list(cfg.targets))
        stages.append(FilterStage(scenario.filter, cfg.targets, frec, rlog, world.gt))
    stages.append(TrackingReport(cfg.targets, prec, frec, world.gt,
                                 visibility=world.track_visibility(),
                                 warmup_s=cfg.detection.period))
    return stages
