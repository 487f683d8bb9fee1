"""The scenario's ``commands`` section: robot commands from the wearer's motion and the robot
following them (Sugiyama & Miura sec. V-C).

Example::

    commands:
      kinds: [move, head, arm]
      head_pose: slam            # slam (head_pose topic) | oracle (ground truth)
      arm_pose: ekf              # ekf (arm_pose topic, the arm section) | oracle

Needs ``robot.base: planar`` for ``move`` and the ``arm`` section for ``arm`` commands from the
EKF; ``head_pose: slam`` needs the ``slam`` section. It drives the robot, so it excludes
``mimic``. Units: m, s; angles in degrees where a key says ``_deg``.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from humimic.control.commands import KINDS, Thresholds
from humimic.control.config import IKConfig
from humimic.scenario.base import Section

_T = Thresholds()


class FollowConfig(Section):
    """How the robot carries out the commands (base: ``control.base``'s limits, 0.4 m/s)."""

    rate: float = Field(105.0, gt=0.0, le=5000.0)
    """IK and servo-target rate (Hz; rounded to ``timing.servo_rate`` divided by a whole
    number); the IK rests while the robot holds still."""
    head_speed: float = Field(1.0, gt=0.0, le=10.0)
    """Peak pan and tilt speed (rad/s) of a head motion (minimum jerk)."""
    arm_speed: float = Field(0.5, gt=0.0, le=5.0)
    """Peak palm speed (m/s) of an arm motion (minimum jerk)."""
    head_tolerance_deg: float = Field(1.0, gt=0.0, le=10.0)
    """A head command has finished when both angles are this close (deg)."""
    arm_tolerance: float = Field(0.02, gt=0.0, le=0.5)
    """An arm command has finished when the palm is this close to its target (m)..."""
    arm_settle_s: float = Field(0.3, gt=0.0, le=5.0)
    """... or has moved less than 1 cm/s for this long (the target is out of reach)."""
    ik: IKConfig = Field(default_factory=lambda: IKConfig(head_cost=0.0))
    """The right arm's IK (the head is commanded, not held: ``head_cost`` 0)."""


class CommandsConfig(Section):
    """Commands for the robot's base, head and right arm from the estimated head and arm."""

    kinds: list[Literal["move", "head", "arm"]] = Field(default_factory=lambda: list(KINDS))
    """Which commands are generated."""
    head_pose: Literal["slam", "oracle"] = "slam"
    """The wearer's head: the ``slam`` stage's ``head_pose``, or the ground truth."""
    arm_pose: Literal["ekf", "oracle"] = "ekf"
    """The Wii remote in the head frame: the ``arm`` stage's ``arm_pose``, or the truth."""
    rate: float = Field(30.0, gt=0.0, le=420.0)
    """How often the conditions are checked (Hz)."""
    longitudinal_m: float = Field(_T.longitudinal_m, gt=0.0, le=10.0)
    """A movement goes out when its target moved more than this along the robot's x (m) ..."""
    lateral_m: float = Field(_T.lateral_m, gt=0.0, le=10.0)
    """... or more than this along its y (m)."""
    head_deg: float = Field(_T.head_deg, gt=0.0, le=90.0)
    """A head rotation goes out when pan and tilt moved more than this in sum (deg)."""
    arm_m: float = Field(_T.arm_m, gt=0.0, le=1.0)
    """An arm motion goes out when the hand target moved more than this (m)."""
    follow: FollowConfig = Field(default_factory=FollowConfig)

    @field_validator("kinds")
    @classmethod
    def _unique(cls, value: list[str]) -> list[str]:
        if not value or len(set(value)) != len(value):
            raise ValueError(f"kinds must list some of {', '.join(KINDS)} once each, got {value}")
        return value

    def thresholds(self) -> Thresholds:
        return Thresholds(self.longitudinal_m, self.lateral_m, self.head_deg, self.arm_m)


def check_commands(scenario) -> None:
    """Cross-section checks of ``commands`` (raise :class:`ScenarioError`, exit status 2)."""
    from humimic.scenario.errors import ScenarioError

    cfg, where = scenario.commands, f"scenario {scenario.name!r}"
    if getattr(scenario, "mimic", None) is not None:
        raise ScenarioError(where, "commands", "commands and mimic both drive the robot",
                            "commands + mimic", "one of them")
    if "move" in cfg.kinds and scenario.robot.base != "planar":
        raise ScenarioError(where, "robot.base", "move commands need a mobile base",
                            scenario.robot.base, "planar, or drop 'move' from commands.kinds")
    if cfg.head_pose == "slam" and getattr(scenario, "slam", None) is None:
        raise ScenarioError(where, "commands.head_pose",
                            "slam needs the scenario's slam section (it publishes head_pose)",
                            "slam", "oracle, or add a slam section")
    if "arm" in cfg.kinds:
        if cfg.arm_pose == "ekf" and getattr(scenario, "arm", None) is None:
            raise ScenarioError(where, "commands.arm_pose",
                                "ekf needs the scenario's arm section (it publishes arm_pose)",
                                "ekf", "oracle, or add an arm section")
        if not scenario.human.wiimote:
            raise ScenarioError(where, "human.wiimote",
                                "arm commands follow the Wii remote: the person must hold it",
                                False, "true, or drop 'arm' from commands.kinds")
