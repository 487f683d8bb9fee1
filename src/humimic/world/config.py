"""Scenario sections that shape the world: the person, the robot and the lighting."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator
from pydantic_core import PydanticCustomError

from humimic.motion.config import MotionConfig, StaticMotion
from humimic.scenario.base import RGB, Section, Vec3
from humimic.world.faces import DEFAULT_IDENTITY, IDENTITY_NAMES
from humimic.world.names import HUMAN_TARGETS, ROBOT_JOINTS
from humimic.world.people import Person
from humimic.world.robot_limits import robot_joint_ranges


class Human(Section):
    """The person: where they stand, what they look like and how they move."""

    distance: float = Field(1.2, gt=0.3, le=4.5)
    """Horizontal distance (m) from the robot's eye midpoint to the person's head centre."""
    lateral: float = Field(0.0, ge=-2.0, le=2.0)
    """Sideways offset (m) along the robot's y axis (left positive)."""
    skin: RGB = (0.87, 0.67, 0.55)
    shirt: RGB = (0.2, 0.3, 0.8)
    trousers: RGB = (0.25, 0.25, 0.3)
    wiimote: bool = False
    """Show the Wii remote in the right hand (it is always simulated; this makes it visible)."""
    identity: str = DEFAULT_IDENTITY
    """The person's face: a name of :data:`humimic.world.faces.IDENTITY_NAMES` or its index."""
    motion: MotionConfig = Field(default_factory=lambda: StaticMotion(kind="static"))

    people: list[Person] = Field(default_factory=list, max_length=3)
    """Other people in the room (lab only), each with a face, clothes and a walk
    (:mod:`humimic.world.people`)."""

    @field_validator("identity", mode="before")
    @classmethod
    def _known_identity(cls, v):
        return check_identity(v)


def check_identity(v):
    """An identity name (or index into :data:`IDENTITY_NAMES`) checked for a validator."""
    if isinstance(v, int) and not isinstance(v, bool):
        if 0 <= v < len(IDENTITY_NAMES):
            return IDENTITY_NAMES[v]
        raise PydanticCustomError("less_than", "identity index out of range",
                                  {"lt": len(IDENTITY_NAMES)})
    if v not in IDENTITY_NAMES:
        expected = ", ".join(f"'{n}'" for n in IDENTITY_NAMES)
        raise PydanticCustomError("literal_error", "unknown identity",
                                  {"expected": f"{expected} or an index 0.."
                                               f"{len(IDENTITY_NAMES) - 1}"})
    return v


class Robot(Section):
    """The humanoid's fixed parameters and initial posture."""

    interocular: float = Field(0.07, gt=0.02, le=0.2)
    """Distance between the eyes (m)."""
    base: Literal["fixed", "planar"] = "fixed"
    """``fixed``: welded at the pelvis (DB); ``planar``: a wheeled base (x, y, yaw joints with
    velocity actuators, driven by :class:`humimic.control.base.BaseController`, at most
    0.4 m/s as Sugiyama & Miura's robot)."""
    pose: Literal["ready", "zero"] | dict[Literal[ROBOT_JOINTS], float] = "ready"
    """Initial joint configuration: a named pose or ``{joint: angle_rad}`` over the ready pose
    (each angle within the joint's limits in ``models/db_humanoid.xml``)."""
    look_at: Literal[tuple(HUMAN_TARGETS)] | Vec3 | None = None
    """Point the eyes (then the head) at a human target or a world point (m) at t = 0."""


    @field_validator("pose")
    @classmethod
    def _pose_within_limits(cls, pose):
        if isinstance(pose, dict):
            ranges = robot_joint_ranges()
            for joint, angle in pose.items():
                lo, hi = ranges[joint]
                if not lo <= angle <= hi:
                    raise ValueError(f"{joint} = {angle:g} rad is outside the joint's limits "
                                     f"[{lo:g}, {hi:g}]")
        return pose


class Lighting(Section):
    ambient: float = Field(0.3, ge=0.0, le=1.0)
    diffuse: float = Field(0.55, ge=0.0, le=1.0)
    shadows: bool = False
    """Shadows cost 10-40x render time on a CPU."""
    msaa: bool = False
