"""Build the mimic stage (and the oracle perception it may use) for a scenario."""

from __future__ import annotations

from humimic.control.oracle import OracleStage
from humimic.control.stage import MimicStage
from humimic.errors import closest
from humimic.pipeline.stage import Stage
from humimic.scenario.errors import ScenarioError


def check_mimic(scenario) -> None:
    """Cross-section checks of ``mimic`` (raise :class:`ScenarioError`, exit status 2)."""
    cfg, where = scenario.mimic, f"scenario {scenario.name!r}"
    base = scenario.timing.servo_rate
    if cfg.servo_rate is not None:
        ratio = base / cfg.servo_rate
        if abs(ratio - round(ratio)) > 1e-9 or ratio < 1:
            raise ScenarioError(where, "mimic.servo_rate", "must divide timing.servo_rate",
                                cfg.servo_rate, f"{base:g} Hz divided by a whole number")
    if cfg.mode == "joints":
        angles = [n for n, t in getattr(scenario, "trackers", {}).items()
                  if t.kind in ("tbp", "kpf")]
        if cfg.tracker is None and not angles:
            raise ScenarioError(where, "mimic.mode", "joints mode needs a tracker that "
                                "estimates arm angles (trackers: with kind tbp or kpf)",
                                "joints", "relative, or add a tbp tracker")
        if cfg.tracker is not None and cfg.tracker not in getattr(scenario, "trackers", {}):
            raise ScenarioError(where, "mimic.tracker", "no such tracker in trackers:",
                                cfg.tracker, ", ".join(angles) or None,
                                closest(cfg.tracker, angles))
        return
    trackers = getattr(scenario, "trackers", None) or {}
    if cfg.gaze.enabled and cfg.gaze.tracker is not None and cfg.gaze.tracker not in trackers:
        raise ScenarioError(where, "mimic.gaze.tracker", "no such tracker in trackers:",
                            cfg.gaze.tracker, ", ".join(trackers) or None,
                            closest(cfg.gaze.tracker, trackers))
    if cfg.perception == "tracked" and getattr(scenario, "filter", None) is None:
        raise ScenarioError(where, "mimic.perception",
                            "tracked perception needs the scenario's perception and filter "
                            "sections (they publish the estimates)", "tracked",
                            "oracle, or add perception and filter sections")


def mimic_stages(scenario, world, rngs, rlog) -> list[Stage]:
    """The oracle (when ``mimic.perception`` is ``oracle``) and the mimic stage."""
    check_mimic(scenario)
    cfg = scenario.mimic
    if cfg.mode == "joints":                    # imitation from tracked joint angles
        from humimic.control.joints import JointMimicStage

        return [JointMimicStage(world, cfg)]
    stages: list[Stage] = []
    if cfg.perception == "oracle":
        stages.append(OracleStage(world, cfg.targets, cfg.oracle, rngs["oracle"]))
    stages.append(MimicStage(world, cfg))
    return stages


def commands_stages(scenario, world, rngs, rlog) -> list[Stage]:
    """The command generator and the robot following it (Sugiyama sec. V-C)."""
    from humimic.control.commands_config import check_commands
    from humimic.control.commands_stage import CommandStage
    from humimic.control.follow import FollowStage

    check_commands(scenario)
    cmd = CommandStage(world, scenario.commands, rlog)
    follow = FollowStage(world, scenario.commands.follow)
    cmd.follower = follow
    return [cmd, follow]
