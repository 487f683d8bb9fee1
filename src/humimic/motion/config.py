"""Scenario configuration of the person's motion: one model per ``kind``, a union on ``kind``.

Units: lengths m, angles rad, times s, frequencies Hz. Positions (``center``, ``right_hand``,
keyframe targets) are palm-centre / head-centre sites in the *avatar* frame: origin on the floor
between the feet, x forward (towards the robot), y to the person's left, z up. The avatar is
1.75 m tall: shoulders at z = 1.43, y = -/+0.18 (right/left); head centre at z = 1.64; an arm
reaches about 0.67 m from the shoulder to the palm centre.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from humimic.errors import unknown_name
from humimic.motion.avatar import JOINT_TYPES, SEGMENTS
from humimic.motion.body_ik import HEAD_DRIVEN_JOINTS
from humimic.scenario.base import Section, Vec3

Hand = Literal["right", "left"]

#: Right palm raised in front of the chest (the default ``static`` pose and motion centre).
RIGHT_HAND_FRONT: Vec3 = (0.30, -0.15, 1.25)
#: Right palm raised beside the head, elbow low and out: the centre of a ``wave``.
RIGHT_HAND_WAVE: Vec3 = (0.10, -0.45, 1.70)
#: Right palm in front of the chest and shoulder: the centre of a ``figure8``.
RIGHT_HAND_FIGURE8: Vec3 = (0.35, -0.15, 1.30)


def mirror(p: Vec3, hand: str) -> Vec3:
    """A right-hand default position mirrored to the left hand (y -> -y) when needed."""
    return p if hand == "right" else (p[0], -p[1], p[2])


class StaticMotion(Section):
    """Hold a pose; optional physiological tremor of the raised hands."""

    kind: Literal["static"] = "static"
    right_hand: Vec3 | None = RIGHT_HAND_FRONT
    """Right palm position (avatar frame, m); ``null`` lets the arm hang."""
    left_hand: Vec3 | None = None
    """Left palm position (avatar frame, m); ``null`` (default) lets the arm hang."""
    tremor: float = Field(0.0, ge=0.0, le=0.02)
    """Tremor RMS displacement per axis (m) of each positioned palm; 0 = none."""
    tremor_frequency: float = Field(9.0, gt=0.0, le=30.0)
    """Centre frequency of the tremor (Hz); physiological tremor is 8-12 Hz."""


class WaveMotion(Section):
    """Wave one hand left-right (along the avatar's y) on an arc about the elbow."""

    kind: Literal["wave"] = "wave"
    hand: Hand = "right"
    amplitude: float = Field(0.25, gt=0.0, le=0.5)
    """Half the side-to-side excursion of the palm (m)."""
    period: float = Field(2.0, gt=0.0)
    center: Vec3 | None = None
    """Mid-wave palm position (avatar frame); default beside the head (mirrored for left)."""
    arc_radius: float = Field(0.35, ge=0.0)
    """Radius (m) of the palm's arc (the forearm pivoting at the elbow); 0 = straight line."""
    ramp: float = Field(1.0, ge=0.0)
    """Smooth fade-in of the amplitude from rest (s)."""

    @model_validator(mode="after")
    def _arc_fits(self) -> WaveMotion:
        if self.arc_radius > 0.0 and self.amplitude >= self.arc_radius:
            raise ValueError(
                f"amplitude {self.amplitude} must be smaller than arc_radius {self.arc_radius}"
                " (or set arc_radius: 0 for a straight line)")
        return self


class AxesMotion(Section):
    """Move a hand in turn along the robot base's x, y, z axes (Ude & Atkeson, Fig. 1)."""

    kind: Literal["axes"] = "axes"
    hand: Hand = "right"
    amplitude: float = Field(0.15, gt=0.0, le=0.4)
    """Excursion (m) to either side of the centre along each axis."""
    duration_per_axis: float = Field(4.0, gt=0.0)
    cycles: int = Field(2, ge=1, le=20)
    """Back-and-forth oscillations along each axis."""
    order: list[Literal["x", "y", "z"]] = Field(default_factory=lambda: ["x", "y", "z"],
                                                min_length=1)
    """Robot-base axes in the order visited; the sequence repeats."""
    center: Vec3 | None = None
    """Palm position the motion oscillates about (avatar frame); default in front of the chest."""


class PointMotion(Section):
    """Slow pointing gestures, to the side and at an angle (Schmidt, Fritsch & Kwolek, Sec. 6:
    six right-hand gestures, three to the side and three to an object in front at ~45 deg)."""

    kind: Literal["point"] = "point"
    hand: Hand = "right"
    gestures: list[Literal["side", "angle"]] = Field(
        default_factory=lambda: ["side"] * 3 + ["angle"] * 3, min_length=1)
    """Gesture sequence (repeats): ``side`` points sideways, ``angle`` forward-sideways."""
    angle: float = Field(math.pi / 4, ge=0.0, le=math.pi / 2)
    """Azimuth of an ``angle`` gesture, from straight ahead towards the hand's side (rad)."""
    elevation: float = Field(0.0, ge=-math.pi / 3, le=math.pi / 3)
    """Elevation of the pointing direction above the horizontal (rad)."""
    reach: float = Field(0.95, ge=0.5, le=1.0)
    """Shoulder-to-palm distance while pointing, as a fraction of the arm's length."""
    move: float = Field(1.5, gt=0.0)
    """Time to raise (and to lower) the arm (s), minimum-jerk profile."""
    hold: float = Field(2.0, ge=0.0)
    rest: float = Field(1.0, ge=0.0)
    """Time the arm hangs between gestures (s); each gesture starts with it."""


class HeadSweepMotion(Section):
    """Move the head left-right: partly by a lateral torso lean, the rest by a sideways body
    shift (see :mod:`humimic.motion.body_ik`); the head stays upright."""

    kind: Literal["head_sweep"] = "head_sweep"
    amplitude: float = Field(0.3, gt=0.0, le=0.6)
    """Lateral head excursion to either side (m); a gaze test sweeps +-0.3 m."""
    period: float = Field(4.0, gt=0.0)
    lean: float = Field(0.25, ge=0.0, le=1.0)
    """Fraction of the excursion produced by leaning the torso (0 = pure body shift)."""
    ramp: float = Field(1.0, ge=0.0)


class Figure8Motion(Section):
    """A hand traces a figure eight (Gerono lemniscate) in the frontal (y-z) plane."""

    kind: Literal["figure8"] = "figure8"
    hand: Hand = "right"
    width: float = Field(0.3, gt=0.0, le=0.8)
    """Total horizontal extent (m)."""
    height: float = Field(0.15, gt=0.0, le=0.6)
    """Total vertical extent (m)."""
    period: float = Field(4.0, gt=0.0)
    center: Vec3 | None = None
    ramp: float = Field(1.0, ge=0.0)


class Keyframe(Section):
    """One time-stamped key: any of palm targets, head target and joint values."""

    t: float = Field(ge=0.0)
    right_hand: Vec3 | None = None
    left_hand: Vec3 | None = None
    head: Vec3 | None = None
    """Head-centre position (avatar frame, m), reached by torso lean + body shift."""
    joints: dict[str, float | Vec3] = Field(default_factory=dict)
    """Joint values: slides (m) and hinges (rad) take a number, ball joints a rotation vector
    ``[rx, ry, rz]`` (axis * angle, rad, relative to the parent body)."""

    @field_validator("joints")
    @classmethod
    def _joint_values(cls, joints: dict[str, float | Vec3]) -> dict[str, float | Vec3]:
        for name, value in joints.items():
            if name not in JOINT_TYPES:
                raise unknown_name("joint", name, JOINT_TYPES)
            if JOINT_TYPES[name] == "ball" and not isinstance(value, tuple):
                raise ValueError(f"{name} is a ball joint: give a rotation vector [rx, ry, rz]")
            if JOINT_TYPES[name] != "ball" and isinstance(value, tuple):
                raise ValueError(f"{name} is a {JOINT_TYPES[name]} joint: give one number")
        return joints


class KeyframesMotion(Section):
    """Time-stamped keys interpolated smoothly; palm targets solved by IK.

    ``spline``: per channel a C2 cubic spline through the keys that specify it, at rest at its
    first and last key (clamped ends), held outside them. ``min_jerk``: a minimum-jerk
    (quintic) segment between consecutive keys, at rest at every key.
    """

    kind: Literal["keyframes"] = "keyframes"
    frames: list[Keyframe] = Field(min_length=1)
    interpolation: Literal["spline", "min_jerk"] = "spline"
    head_lean: float = Field(0.25, ge=0.0, le=1.0)
    """Fraction of a head target's horizontal displacement produced by torso lean."""

    @model_validator(mode="after")
    def _consistent(self) -> KeyframesMotion:
        times = [f.t for f in self.frames]
        for i in range(1, len(times)):
            if times[i] <= times[i - 1]:
                raise ValueError(f"frame times must increase: frames[{i}].t = {times[i]} "
                                 f"is not after frames[{i - 1}].t = {times[i - 1]}")
        joints = {j for f in self.frames for j in f.joints}
        clashes = {
            "head": joints & set(HEAD_DRIVEN_JOINTS),
            "right_hand": joints & {"r_shoulder", "r_elbow", "r_wrist"},
            "left_hand": joints & {"l_shoulder", "l_elbow", "l_wrist"},
        }
        for target, clash in clashes.items():
            if clash and any(getattr(f, target) is not None for f in self.frames):
                raise ValueError(f"{target} targets drive {', '.join(sorted(clash))}: "
                                 "do not give those joints as well")
        return self


class BVHMotion(Section):
    """Play back a BVH motion-capture clip retargeted onto the avatar."""

    kind: Literal["bvh"] = "bvh"
    file: Path
    """The BVH file (the scenario loader resolves it relative to the scenario file)."""
    start: float = Field(0.0, ge=0.0)
    """Clip time (s) shown at motion time 0."""
    speed: float = Field(1.0, gt=0.0, le=10.0)
    """Playback speed factor (clip seconds per motion second)."""
    duration: float | None = Field(None, gt=0.0)
    """Motion seconds to play (default: to the clip's end); the last pose is held after it."""
    scale: float | None = Field(None, gt=0.0)
    """Metres per BVH unit for the root's translation; default: the avatar's leg length over
    the BVH skeleton's (the skeleton itself always takes the avatar's 1.75 m proportions)."""
    face_robot: bool = True
    """Turn the clip about the vertical so the person faces the robot at the start."""
    smoothing: float | None = Field(6.0, gt=0.0)
    """Low-pass cut-off (Hz, clip time) of a zero-phase Butterworth filter on the retargeted
    joint trajectories; motion capture is noisy and its second differences at 120 Hz reach
    100 m/s^2. 6 Hz is Winter's choice for human movement; ``null`` plays the raw frames."""
    skip_reference: bool = True
    """Drop a leading reference pose (a first frame that jumps faster than a human can move,
    as in the CMU conversions); clip time 0 is then the first motion frame."""
    joint_map: dict[str, str] | None = None
    """Avatar segment -> BVH joint overrides (segments: pelvis, chest, head, r/l_upper_arm,
    r/l_forearm, r/l_hand, r/l_thigh, r/l_shank, r/l_foot); default CMU/MotionBuilder names."""

    @field_validator("joint_map")
    @classmethod
    def _segments(cls, joint_map: dict[str, str] | None) -> dict[str, str] | None:
        for seg in joint_map or {}:
            if seg not in SEGMENTS:
                raise unknown_name("avatar segment", seg, SEGMENTS)
        return joint_map


# ---- locomotion (Sugiyama & Miura's wearer) ----------------------------------------------------
Frame = Literal["W", "avatar"]


def _increasing(name: str, times: list[float]) -> None:
    for i in range(1, len(times)):
        if times[i] <= times[i - 1]:
            raise ValueError(f"{name} times must increase: {name}[{i}].t = {times[i]} is not "
                             f"after {name}[{i - 1}].t = {times[i - 1]}")


class Waypoint(Section):
    """Where the person stands (the point between the feet) at time ``t``."""

    t: float = Field(ge=0.0)
    at: tuple[float, float]
    """``(x, z)`` in the paper's frame W (m), or ``(x, y)`` in the avatar frame with
    ``frame: avatar``."""
    heading_deg: float | None = None
    """Facing direction (deg): 0 = W's +z, towards the screen (the avatar's +x with ``frame:
    avatar``), positive turning left. Default: the previous waypoint's (the first's: 0)."""


class HandKey(Section):
    """A palm target at time ``t`` in the walking body's frame: the avatar frame carried along
    by the body (x forward, y left, z up from the floor; it bobs and sways with the walk)."""

    t: float = Field(ge=0.0)
    p: Vec3


class LookKey(Section):
    """Head orientation relative to the body at time ``t`` (neck)."""

    t: float = Field(ge=0.0)
    yaw_deg: float = Field(0.0, ge=-80.0, le=80.0)
    """Turn to the left (+) or right (-)."""
    pitch_deg: float = Field(0.0, ge=-60.0, le=45.0)
    """Look up (+) or down (-)."""


class WalkMotion(Section):
    """Walk through timed waypoints: the root follows them (minimum jerk: at rest at each, or a
    spline through them), turns to each heading, and bobs, sways and swings legs and arms at
    the step frequency while it moves (:mod:`humimic.motion.gait`). Hands may follow keyframes
    in the body frame (the right hand holds the Wii remote pointing forward); the head may look
    around (``look``)."""

    kind: Literal["walk"] = "walk"
    frame: Frame = "W"
    """Frame of the waypoints: the paper's W (``(x, z)``) or the avatar frame (``(x, y)``)."""
    waypoints: list[Waypoint] = Field(min_length=1)
    interpolation: Literal["min_jerk", "spline"] = "min_jerk"
    step_frequency: float = Field(2.0, gt=0.0, le=4.0)
    """Steps per second (Hz); a stride is two steps."""
    bob: float = Field(0.04, ge=0.0, le=0.1)
    """Vertical excursion of the body, peak to peak, while walking (m)."""
    sway: float = Field(0.04, ge=0.0, le=0.15)
    """Lateral excursion of the body, peak to peak, while walking (m)."""
    nominal_speed: float = Field(0.5, gt=0.0, le=3.0)
    """Speed (m/s) at which the gait reaches 76 % of its amplitudes (``tanh(v / v_n)``)."""
    right_hand: list[HandKey] | None = None
    """Right palm keyframes (body frame, minimum jerk between keys); default: arm swing."""
    left_hand: list[HandKey] | None = None
    look: list[LookKey] = Field(default_factory=list)
    """Head keyframes (minimum jerk between keys); default: looking straight ahead."""

    @model_validator(mode="after")
    def _times(self) -> WalkMotion:
        _increasing("waypoints", [w.t for w in self.waypoints])
        for key in ("right_hand", "left_hand", "look"):
            _increasing(key, [k.t for k in getattr(self, key) or []])
        return self


class JumpMotion(Section):
    """Jump in place (Sugiyama & Miura, Fig. 8): crouch, push off, a ballistic flight of
    ``height``, land, rise (:func:`humimic.motion.gait.jump_profile`); arms hang."""

    kind: Literal["jump"] = "jump"
    frame: Frame = "W"
    at: tuple[float, float] | None = None
    """Where (``(x, z)`` in W or ``(x, y)`` in the avatar frame); default: where the room puts
    the person."""
    heading_deg: float = 0.0
    """Facing direction (deg), as a waypoint's."""
    start: float = Field(1.0, ge=0.0)
    """Time (s) the first jump begins (its crouch)."""
    count: int = Field(1, ge=1, le=100)
    period: float = Field(3.0, gt=0.0)
    """Time (s) between the starts of consecutive jumps (at least one jump's duration)."""
    height: float = Field(0.2, gt=0.0, le=0.8)
    """Rise of the body in flight (m)."""
    crouch: float = Field(0.15, gt=0.0, le=0.4)
    """Depth of the crouch before take-off and after landing (m)."""

    @model_validator(mode="after")
    def _fits(self) -> JumpMotion:
        from humimic.motion.gait import jump_duration

        need = jump_duration(self.height)
        if self.count > 1 and self.period < need:
            raise ValueError(f"period {self.period} s is shorter than one jump "
                             f"({need:.2f} s at height {self.height} m)")
        return self


MotionConfig = Annotated[
    StaticMotion | WaveMotion | AxesMotion | PointMotion | HeadSweepMotion | Figure8Motion
    | KeyframesMotion | BVHMotion | WalkMotion | JumpMotion,
    Field(discriminator="kind"),
]
