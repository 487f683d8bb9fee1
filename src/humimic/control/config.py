"""The scenario's ``mimic`` section: what the robot imitates, how, and with which perception.

Example (every key optional except what differs from the defaults)::

    mimic:
      map: {right_hand: R_palm}     # human target -> robot site it drives
      mode: relative                # relative (paper) | mirrored | follow (Fig. 4)
      scale: auto                   # auto (robot arm / person's arm) | a number
      fit: {enabled: true, margin: 0.03, time_constant: 0.3, strain_rate: 0.5}
      start: 0.0                    # s: the first estimate at/after this time starts mimicry
      perception: oracle            # oracle (ground truth + noise) | tracked (perception+filter)
      oracle: {noise_std: 0.0, latency: 0.0}
      interpolation: {mode: hold, omega: 60.0}
      gaze: {enabled: true, target: head}

Units: m, s, rad, Hz. Robot sites and human targets are the names in
:mod:`humimic.world.names`.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, Field, field_validator, model_validator

from humimic.errors import unknown_name
from humimic.scenario.base import Section
from humimic.world.names import HUMAN_TARGETS

#: Robot sites a human part may drive (hands and elbows).
DRIVABLE_SITES = ("R_palm", "L_palm", "R_elbow", "L_elbow")
#: Robot sites that exist but may not be driven, and why.
UNDRIVABLE_SITES = {
    "L_eye": "is an eye: the eyes are the cameras and only gaze moves them",
    "R_eye": "is an eye: the eyes are the cameras and only gaze moves them",
    "eye_center": "is the eyes' base: it is kept still so the stereo calibration stays valid",
    "head": "is kept still (the eyes' base) so the stereo calibration stays valid",
    "base": "is the fixed pelvis",
}
Mode = Literal["relative", "mirrored", "follow", "joints"]

#: The map used when a scenario gives none, per mode.
DEFAULT_MAPS: dict[str, dict[str, str]] = {
    "relative": {"right_hand": "R_palm"},
    "mirrored": {"right_hand": "L_palm"},
    "follow": {"head": "R_palm"},
    "joints": {},
}


def check_human_target(name: str) -> str:
    if name not in HUMAN_TARGETS:
        raise unknown_name("human target", name, HUMAN_TARGETS)
    return name


#: A human target's name, checked (an unknown one fails with the valid names).
HumanTarget = Annotated[str, AfterValidator(check_human_target)]


def check_robot_site(name: str) -> str:
    if name in UNDRIVABLE_SITES:
        raise ValueError(f"robot site {name!r} cannot be driven: it {UNDRIVABLE_SITES[name]}; "
                         f"drivable sites: {', '.join(DRIVABLE_SITES)}")
    if name not in DRIVABLE_SITES:
        raise unknown_name("robot site", name, DRIVABLE_SITES)
    return name


class OracleConfig(Section):
    """Oracle perception: ground truth of the targets, optionally noisy and late, published as
    ``estimates`` at the camera rate (the tracked pipeline's interface)."""

    noise_std: float = Field(0.0, ge=0.0, le=0.5)
    """White position noise per axis (m)."""
    velocity_noise_std: float = Field(0.0, ge=0.0, le=10.0)
    """White velocity noise per axis (m/s)."""
    acceleration_noise_std: float = Field(0.0, ge=0.0, le=500.0)
    """White acceleration noise per axis (m/s^2)."""
    latency: float = Field(0.0, ge=0.0, le=0.5)
    """Photon-to-estimate latency (s), added to the cameras' transfer latency."""
    require_in_view: bool = True
    """Report a target only while it projects inside every eye camera's image."""


class FitConfig(Section):
    """Fit the person's motion range into the robot's reach by shrinking the scale (see
    :mod:`humimic.control.mapping`): when a mapped displacement would leave the driven site's
    reachable shell, the scale decays towards the largest one that keeps it inside, and while
    the arm is strained (IK miss, a joint on its limit band) it shrinks steadily; it never
    grows back."""

    enabled: bool = True
    margin: float = Field(0.03, ge=0.0, le=0.2)
    """Distance (m) the fitted motion keeps inside the reachable shell (room for the PD's
    overshoot and the IK's joint limits)."""
    time_constant: float = Field(0.3, ge=0.0, le=10.0)
    """Time constant (s) of the scale's decay: 0 jumps at once; longer ignores brief outliers
    (a mis-tracked frame) but clamps longer while the scale settles."""
    strain_rate: float = Field(0.5, ge=0.0, le=20.0)
    """Relative rate (1/s) at which the scale shrinks while the arm is strained: the IK misses
    the command by more than ``tolerance`` or a shoulder or elbow joint sits on its limit band
    (0: the IK is not listened to)."""
    tolerance: float = Field(0.005, gt=0.0, le=0.1)
    """IK miss (m) beyond which the arm counts as strained."""


class InterpolationConfig(Section):
    """Cartesian PD interpolation from the vision rate to the servo rate (Ude & Atkeson)."""

    mode: Literal["hold", "extrapolate"] = "hold"
    """hold: PD on the latest estimate as received (the paper); extrapolate: PD on the latest
    estimate predicted to the current time with its v and a (cancels the vision latency)."""
    omega: float = Field(20.0, gt=0.0, le=400.0)
    """Natural frequency of the PD (rad/s): kp = omega^2, kd = 2 zeta omega."""
    zeta: float = Field(1.0, gt=0.0, le=5.0)
    """Damping ratio of the PD (1 = critically damped)."""
    feedforward: Literal["acceleration", "velocity", "none"] = "acceleration"
    """Estimate derivatives fed forward into the PD: v and a (the paper), v only, or none
    (a pure PD on the position: smoother on noisy estimates, but lags)."""


class IKConfig(Section):
    """Redundant differential IK (mink + daqp) at the servo rate."""

    site_cost: float = Field(5.0, gt=0.0)
    """Cost of a driven site's position error (per m)."""
    head_cost: float = Field(20.0, ge=0.0)
    """Cost of moving the eyes' base (per m and per rad): keeps the head still."""
    posture_cost: float = Field(0.02, ge=0.0)
    """Cost pulling the arms and head towards the rest pose (per rad)."""
    torso_cost: float = Field(1.0, ge=0.0)
    """Posture cost of the torso joints (per rad). The IK may turn the torso for reach while the
    neck turns back (the head task), but the physical trunk and neck servos do not cancel
    exactly in transients: at 0.2 an arm straining at its limits moved the eyes 12 mm, at 1.0
    under 5 mm. A jerky arm on its limit band still turns the waist: 20 kept the head within
    0.041 deg instead of 0.124 at 2.2 m, at some cost in reach (``docs/ude_control_notes.md``)."""
    limit_margin: float = Field(0.03, gt=0.0, le=0.3)
    """Distance (rad) the IK keeps from every joint limit."""
    max_joint_speed: float = Field(5.0, gt=0.0, le=50.0)
    """Joint speed limit (rad/s) for torso, head and arms (legs: 1 rad/s)."""
    collision_margin: float = Field(0.02, ge=0.0, le=0.2)
    """Minimum distance (m) kept between the arms and the torso, head, legs and other arm."""
    damping: float = Field(1e-4, ge=0.0, le=1.0)
    """Levenberg-Marquardt damping of the QP."""


class ServoConfig(Section):
    feedforward: Literal["none", "velocity", "inertia", "dynamics"] = "dynamics"
    """What the position servos get besides the IK's joint targets: nothing, the joint
    velocities (cancels the servo's damping lag), velocities plus M(q) qdd (``inertia``:
    cancels the inertial lag), or velocities plus the inverse dynamics M(q) qdd + c(q, qdot)
    (``dynamics``: also the Coriolis and centrifugal forces, which the trunk and neck would
    otherwise take from a waving arm: the head nods; :mod:`humimic.control.servo`)."""


class GazeConfig(Section):
    """Active gaze: the eyes keep a target near the centre of their images."""

    enabled: bool = False
    target: str = "head"
    """Human target to look at."""
    camera: Literal["wide", "foveal"] = "wide"
    """Image in which the target is scored (wide and foveal cameras are coaxial)."""
    max_speed: float = Field(10.0, gt=0.0, le=50.0)
    """Eye speed limit (rad/s)."""
    lead: bool = True
    """Predict the target to the current time with its estimated v and a."""
    tracker: str | None = None
    """Look at the pose this tracker (its name under ``trackers:``) publishes on ``poses`` for
    ``target`` (``right_hand`` -> the pose's ``r_hand``), while it reports ``tracking``,
    instead of the estimates (e.g. GEST on the foveal pair, its hand kept in the narrow
    view); the eyes hold while it does not track."""
    midpoint_with: HumanTarget | None = None
    """With ``tracker``: look at the midpoint of the pose's ``target`` and this target (e.g.
    ``right_elbow`` with ``right_wrist``: the forearm's middle, the kpf's foveal view of the
    forearm and hand, ``trackers.<kpf>.fovea``); None: at ``target``."""

    @field_validator("target")
    @classmethod
    def _check_target(cls, value: str) -> str:
        return check_human_target(value)

    @model_validator(mode="after")
    def _midpoint_needs_tracker(self) -> GazeConfig:
        if self.midpoint_with is not None and self.tracker is None:
            raise ValueError("gaze.midpoint_with needs gaze.tracker (a tracker's pose)")
        return self


class MimicConfig(Section):
    """Imitation: human targets drive robot sites through the relative-motion mapping."""

    mode: Mode = "relative"
    """relative: the robot site's displacement equals the human part's (robot base frame, the
    paper); mirrored: as a mirror image across the space between them (depth reversed);
    follow: a robot hand follows the person's head (Fig. 4); joints: the arm angles a tracker
    publishes on ``poses`` drive DB's arm joints (Menezes sec. 7.2,
    :mod:`humimic.control.joints`; ``map`` is not used)."""
    map: dict[str, str] | None = None
    """Human target -> robot site, e.g. ``{right_hand: R_palm}``; default per mode:
    relative ``{right_hand: R_palm}``, mirrored ``{right_hand: L_palm}``, follow
    ``{head: R_palm}``, joints ``{}``."""
    tracker: str | None = None
    """``joints`` mode: the name (under ``trackers:``) of the tracker whose angles drive the
    robot; default the first that publishes arm angles."""
    scale: float | Literal["auto"] = "auto"
    """Displacement scale at the start: a number, or ``auto``: the driven robot arm's length
    over the person's (shoulder to palm; shoulder to elbow for an elbow site). ``fit`` may
    shrink it; ``mimicry.<site>.scale`` reports the one in use at the end."""
    fit: FitConfig = Field(default_factory=FitConfig)
    relative_to: HumanTarget | None = None
    """Human target whose motion is subtracted first (e.g. ``pelvis``): the mapped motion is
    then the part's motion relative to the body, not the whole body's travel."""
    start: float = Field(0.0, ge=0.0)
    """Mimicry starts with the first estimate whose photon time is at or after this (s)."""
    servo_rate: float | None = Field(None, gt=0.0)
    """IK/servo rate (Hz); default: ``timing.servo_rate``. Must divide it."""
    perception: Literal["oracle", "tracked"] = "oracle"
    """oracle: ground truth through :class:`OracleConfig`; tracked: the ``estimates`` of the
    scenario's perception and filter stages."""
    oracle: OracleConfig = Field(default_factory=OracleConfig)
    interpolation: InterpolationConfig = Field(default_factory=InterpolationConfig)
    ik: IKConfig = Field(default_factory=IKConfig)
    servo: ServoConfig = Field(default_factory=ServoConfig)
    gaze: GazeConfig = Field(default_factory=GazeConfig)
    clamp_workspace: bool = True
    """Clamp commands into each driven site's reachable shell (reported in the metrics); off
    also turns ``fit`` off (it fits into that shell)."""

    @field_validator("map")
    @classmethod
    def _check_map(cls, value: dict[str, str] | None, info) -> dict[str, str] | None:
        if value is None:
            return None
        if not value and info.data.get("mode") != "joints":  # joints mode maps no site
            raise ValueError("map is empty: give at least one {human_target: robot_site}")
        seen: dict[str, str] = {}
        for target, site in value.items():
            check_human_target(target)
            check_robot_site(site)
            if site in seen:
                raise ValueError(f"robot site {site!r} is driven by both {seen[site]!r} and "
                                 f"{target!r}; each site takes one human target")
            seen[site] = target
        return value

    @field_validator("scale", mode="before")
    @classmethod
    def _check_scale(cls, value):
        allowed = "allowed: auto, or a number > 0 and <= 5"
        if value == "auto":
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"not a scale; {allowed}")
        if not 0.0 < value <= 5.0:
            raise ValueError(f"out of range; {allowed}")
        return float(value)

    @model_validator(mode="after")
    def _fill_map(self) -> MimicConfig:
        if self.map is None:
            object.__setattr__(self, "map", dict(DEFAULT_MAPS[self.mode]))
        if self.relative_to is not None and self.relative_to in self.map:
            raise ValueError(f"relative_to {self.relative_to!r} is also mapped: its motion "
                             "relative to itself is zero")
        return self

    @property
    def targets(self) -> list[str]:
        """Every human target mimicry needs an estimate of (map, then gaze)."""
        out = list(self.map or {})
        if self.relative_to is not None:
            out.append(self.relative_to)
        if self.gaze.enabled and self.gaze.tracker is None and self.gaze.target not in out:
            out.append(self.gaze.target)
        return out
