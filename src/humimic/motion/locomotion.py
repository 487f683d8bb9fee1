"""The walking and jumping person (Sugiyama & Miura's wearer) as :class:`HumanMotion`\\ s.

A walk is given by timed waypoints (in the paper's W or the avatar frame, converted with the
context's ``T_avatar_W``): the root follows them with a heading, the gait of
:mod:`humimic.motion.gait` rides on top (bob, sway, legs, arms), palm keyframes are given in the
walking body's frame and solved by the arm IK with the palms facing inwards (the right hand's
Wii remote then points along the forearm, buttons up), and the head may look around. A jump
holds the root in place and lifts it along :func:`~humimic.motion.gait.jump_profile`, the legs
bending so the feet stay on the floor while the body is lower than standing.
"""

from __future__ import annotations

import numpy as np

from humimic.motion import quat
from humimic.motion.avatar import AvatarGeometry
from humimic.motion.config import JumpMotion, WalkMotion
from humimic.motion.context import PRIMITIVE_RATE, MotionContext
from humimic.motion.gait import (
    activity,
    bob_and_sway,
    flexion_rotvec,
    jump_profile,
    leg_swing,
    pitch_rotvec,
    squat_legs,
)
from humimic.motion.keyframes import channel_path
from humimic.motion.pose import PoseTargets, pose_diagnostics, solve_pose

#: Step (s) of the central differences giving the path's speed and turning rate.
_H = 1e-3
#: Palm directions in the body frame: palms facing inwards.
_PALMS = {"right_hand": np.array([0.0, 1.0, 0.0]), "left_hand": np.array([0.0, -1.0, 0.0])}


def body_to_avatar(p_body: np.ndarray, origin: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """Points ``(N, 3)`` of the walking body's frame (origin ``(N, 3)``, heading ``psi``) in
    the avatar frame."""
    return origin + np.einsum("nij,nj->ni", quat.rot_z(psi), p_body)


def look_rotvec(yaw: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """Neck rotation vectors for a head turned by ``yaw`` (left +) then pitched up by ``pitch``."""
    R = quat.rot_z(yaw) @ quat.rot_y(-pitch)
    return quat.to_rotvec(quat.from_matrix(R))


class Walk:
    """:class:`~humimic.motion.config.WalkMotion` on the avatar (see the module docstring)."""

    sample_rate = PRIMITIVE_RATE

    def __init__(self, c: WalkMotion, ctx: MotionContext):
        self.c, self.geometry = c, ctx.geometry
        times = np.array([w.t for w in c.waypoints])
        at = np.array([w.at for w in c.waypoints], float)
        headings, last = [], 0.0
        for w in c.waypoints:
            last = last if w.heading_deg is None else w.heading_deg
            headings.append(last)
        if c.frame == "W":
            xy, psi = ctx.W_to_avatar(at, np.array(headings))
        else:
            xy, psi = at, np.radians(headings)
        self._path = channel_path(times, np.c_[xy, psi], c.interpolation)
        self._hands = {key: channel_path(np.array([k.t for k in keys]),
                                         np.array([k.p for k in keys]), "min_jerk")
                       for key in ("right_hand", "left_hand")
                       if (keys := getattr(c, key))}
        self._look = (channel_path(np.array([k.t for k in c.look]),
                                   np.radians([[k.yaw_deg, k.pitch_deg] for k in c.look]),
                                   "min_jerk") if c.look else None)

    def root(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Floor position ``(N, 2)`` and heading ``(N,)`` (avatar frame) of the waypoint path,
        and the gait activity ``(N,)``."""
        t = np.atleast_1d(np.asarray(t, float))
        x = self._path(t)
        dx = (self._path(t + _H) - self._path(t - _H)) / (2 * _H)
        act = activity(np.hypot(dx[:, 0], dx[:, 1]), dx[:, 2], self.c.nominal_speed)
        return x[:, :2], x[:, 2], act

    def _solve(self, t: np.ndarray):
        t = np.atleast_1d(np.asarray(t, float))
        c, g = self.c, self.geometry
        xy, psi, act = self.root(t)
        bob, sway = bob_and_sway(t, act, c.step_frequency, c.bob, c.sway)
        origin = np.c_[xy, bob] + sway[:, None] * np.c_[-np.sin(psi), np.cos(psi),
                                                         np.zeros_like(psi)]
        legs = leg_swing(t, act, c.step_frequency)
        joints = {"root_x": origin[:, 0], "root_y": origin[:, 1], "root_z": origin[:, 2],
                  "root_rot": np.c_[np.zeros((len(t), 2)), psi]}
        for side, hand in (("r", "right_hand"), ("l", "left_hand")):
            joints[f"{side}_hip"] = flexion_rotvec(legs[f"{side}_hip"])
            joints[f"{side}_knee"] = legs[f"{side}_knee"]
            joints[f"{side}_ankle"] = pitch_rotvec(legs[f"{side}_ankle"])
            if hand not in self._hands:
                joints[f"{side}_shoulder"] = flexion_rotvec(legs[f"{side}_arm"])
        if self._look is not None:
            yp = self._look(t)
            joints["neck"] = look_rotvec(yp[:, 0], yp[:, 1])
        hands = {key: body_to_avatar(path(t), origin, psi) for key, path in self._hands.items()}
        palms = {key: np.einsum("nij,j->ni", quat.rot_z(psi), d) for key, d in _PALMS.items()}
        return solve_pose(len(t), PoseTargets(**hands, joints=joints), g, palm_dir=palms)

    def sample(self, t: np.ndarray) -> np.ndarray:
        return self._solve(t)[0]

    def diagnostics(self, t: np.ndarray) -> dict[str, float]:
        q, ik = self._solve(t)
        return pose_diagnostics(q, ik, self.geometry)


class Jump:
    """:class:`~humimic.motion.config.JumpMotion` on the avatar (see the module docstring)."""

    sample_rate = PRIMITIVE_RATE

    def __init__(self, c: JumpMotion, ctx: MotionContext):
        self.c, self.geometry = c, ctx.geometry
        at = np.zeros(2) if c.at is None else np.array(c.at, float)
        if c.frame == "W":
            xy, self.psi = ctx.W_to_avatar(at, c.heading_deg)
            self.xy = xy if c.at is not None else np.zeros(2)  # None: where the room puts them
        else:
            self.xy, self.psi = at, np.radians(c.heading_deg)
        g: AvatarGeometry = ctx.geometry
        self.leg = g.thigh + g.shank

    def height(self, t: np.ndarray) -> np.ndarray:
        """Vertical offset of the body from standing (m) at ``t``."""
        t = np.atleast_1d(np.asarray(t, float))
        c = self.c
        return sum(jump_profile(t, c.start + k * c.period, c.height, c.crouch)
                   for k in range(c.count))

    def sample(self, t: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, float))
        n = len(t)
        z = self.height(t)
        hip, knee, ankle = squat_legs(-z, self.leg)
        hip_r, ankle_r = flexion_rotvec(hip), pitch_rotvec(ankle)
        joints = {"root_x": np.full(n, self.xy[0]), "root_y": np.full(n, self.xy[1]),
                  "root_z": z, "root_rot": np.tile([0.0, 0.0, float(self.psi)], (n, 1))}
        for side in ("r", "l"):
            joints[f"{side}_hip"], joints[f"{side}_knee"], joints[f"{side}_ankle"] = (
                hip_r, knee, ankle_r)
        return solve_pose(n, PoseTargets(joints=joints), self.geometry)[0]

    def diagnostics(self, t: np.ndarray) -> dict[str, float]:
        return pose_diagnostics(self.sample(t), {}, self.geometry)


def make_walk(c: WalkMotion, ctx: MotionContext) -> Walk:
    return Walk(c, ctx)


def make_jump(c: JumpMotion, ctx: MotionContext) -> Jump:
    return Jump(c, ctx)
