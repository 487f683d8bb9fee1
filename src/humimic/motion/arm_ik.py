"""Analytic arm IK: put the avatar's palm-centre site at a target (vectorised over samples).

The arm is a ball shoulder, a hinge elbow (axis -y of the upper arm, + = flexion) and a ball
wrist; every segment offset lies along its body's -z (checked by
:meth:`AvatarGeometry.from_model`). The hand's long axis is kept on the forearm's axis (no wrist
flexion or deviation), so the palm site is ``L2 = forearm + palm`` along the forearm from the
elbow and the position problem is a two-link chain, solved in closed form:

* elbow flexion from the law of cosines, ``d^2 = L1^2 + L2^2 + 2 L1 L2 cos(theta)``;
* swivel (the elbow's position on its circle about the shoulder-target line): the elbow is
  pushed towards a preferred direction in the chest frame, down, out and slightly back
  (:data:`ELBOW_PREFERENCE`), projected perpendicular to the shoulder-target line. This keeps
  the elbow low and outside for a raised hand, as people do;
* the upper arm's frame follows from the arm plane: z = -(upper-arm direction), y = w x v with
  ``w`` the target direction and ``v`` the elbow's swivel direction (so flexion is >= 0 and the
  hinge is well defined even for a straight arm);
* wrist: a pure twist about the forearm axis that turns the palm towards ``palm_dir`` (by
  default towards the robot, so a waving palm faces it). The exact twist angle is computed with
  a softened half-angle formula (smooth everywhere) and saturated smoothly below the wrist's
  range (``limit * tanh(angle / limit)``).

Targets outside the reachable shell ``[d_min, L1 + L2]`` (d_min from the elbow's flexion limit)
are clamped onto it along the shoulder-target line and reported in :class:`ArmIKResult`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.motion import quat
from humimic.motion.avatar import AvatarGeometry

#: Preferred elbow direction (chest frame) for the right arm; the left arm mirrors y.
ELBOW_PREFERENCE = np.array([-0.25, -0.45, -1.0])
#: Softening of the half-angle twist formula near a forearm parallel to ``palm_dir``.
TWIST_SOFTENING = 0.05
#: Margin (rad) kept between the saturated wrist twist and the wrist's range.
TWIST_MARGIN = 0.1


@dataclass(frozen=True)
class ArmIKResult:
    """Joint values for one arm (N samples) and what was actually reached."""

    q_shoulder: np.ndarray
    """(N, 4) shoulder ball quaternion (upper arm relative to chest)."""
    elbow: np.ndarray
    """(N,) elbow flexion (rad)."""
    q_wrist: np.ndarray
    """(N, 4) wrist ball quaternion (hand relative to forearm), a twist about z."""
    p_reached: np.ndarray
    """(N, 3) palm position the solution reaches, avatar frame (the clamped target)."""
    reachable: np.ndarray
    """(N,) bool: the requested target was inside the reachable shell."""
    clamp_distance: np.ndarray
    """(N,) distance (m) from the requested to the reached target (0 when reachable)."""


def arm_lengths(g: AvatarGeometry) -> tuple[float, float]:
    """``L1`` shoulder->elbow and ``L2`` elbow->palm site (m)."""
    return g.upper_arm, g.forearm + g.palm


def reach_limits(g: AvatarGeometry, side: str = "r") -> tuple[float, float]:
    """Closest and farthest palm distances from the shoulder (m)."""
    L1, L2 = arm_lengths(g)
    theta_max = g.ranges[f"{side}_elbow"][1]
    theta_max = np.pi if not np.isfinite(theta_max) else min(theta_max, np.pi)
    d_min = np.sqrt(max(L1 * L1 + L2 * L2 + 2 * L1 * L2 * np.cos(theta_max), 0.0))
    return float(d_min), L1 + L2


def elbow_flexion(d: np.ndarray, L1: float, L2: float) -> np.ndarray:
    """Elbow flexion (rad) that puts the palm at distance ``d`` from the shoulder (cosine law)."""
    c = (d * d - L1 * L1 - L2 * L2) / (2 * L1 * L2)
    return np.arccos(np.clip(c, -1.0, 1.0))


def swivel_direction(w: np.ndarray, pref: np.ndarray) -> np.ndarray:
    """Unit vector perpendicular to ``w`` closest to ``pref`` (falls back to -x if parallel)."""
    v = pref - np.sum(pref * w, axis=-1, keepdims=True) * w
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    back = np.array([-1.0, 0.0, 0.0])
    alt = back - np.sum(back * w, axis=-1, keepdims=True) * w
    v = np.where(n > 1e-6, v, alt)
    return quat.normalize(v)


def wrist_twist(axis: np.ndarray, n0: np.ndarray, d: np.ndarray, limit: float) -> np.ndarray:
    """Twist (rad, about ``axis``) turning palm normal ``n0`` towards ``d``, saturated at ``limit``.

    With ``d_perp`` the part of ``d`` perpendicular to the axis and ``phi`` the angle from ``n0``
    to it, ``2 atan2(|d_perp| sin phi, |d_perp| (1 + cos phi) + eps)`` is ``phi`` for a clear
    ``d_perp`` and goes smoothly to 0 where ``d`` is parallel to the axis.
    """
    d_perp = d - np.sum(d * axis, axis=-1, keepdims=True) * axis
    s = np.sum(axis * np.cross(n0, d_perp), axis=-1)
    c = np.sum(n0 * d_perp, axis=-1)
    tau = 2.0 * np.arctan2(s, np.linalg.norm(d_perp, axis=-1) + c + TWIST_SOFTENING)
    return limit * np.tanh(tau / limit)


def solve_arm(
    side: str,
    p_avatar_target: np.ndarray,
    R_avatar_chest: np.ndarray,
    p_avatar_chest: np.ndarray,
    g: AvatarGeometry,
    palm_dir_avatar: np.ndarray | None = None,
) -> ArmIKResult:
    """Place the ``side`` (``"r"``/``"l"``) palm site at ``p_avatar_target`` (N, 3).

    ``R_avatar_chest`` (N, 3, 3) and ``p_avatar_chest`` (N, 3) are the chest pose (from the
    root and spine, see :func:`humimic.motion.avatar.chest_pose`). ``palm_dir_avatar`` ((3,) or
    (N, 3), default avatar +x) is where the palm should face.
    """
    p_target = np.atleast_2d(np.asarray(p_avatar_target, float))
    n = len(p_target)
    R_c = np.broadcast_to(R_avatar_chest, (n, 3, 3))
    L1, L2 = arm_lengths(g)
    d_min, d_max = reach_limits(g, side)
    mirror = np.array([1.0, -1.0 if side == "l" else 1.0, 1.0])

    # Target relative to the shoulder, in the chest frame.
    rel = np.einsum("nji,nj->ni", R_c, p_target - p_avatar_chest) - g.shoulder[side]
    d_req = np.linalg.norm(rel, axis=-1)
    w = np.where(d_req[:, None] > 1e-9, rel / np.maximum(d_req, 1e-9)[:, None], [0.0, 0.0, -1.0])
    d = np.clip(d_req, d_min, d_max)
    reachable = (d_req >= d_min - 1e-9) & (d_req <= d_max + 1e-9)

    theta = elbow_flexion(d, L1, L2)
    cos_b = np.clip((L1 * L1 + d * d - L2 * L2) / (2 * L1 * d), -1.0, 1.0)
    v = swivel_direction(w, ELBOW_PREFERENCE * mirror)
    u = cos_b[:, None] * w + np.sqrt(1 - cos_b * cos_b)[:, None] * v  # upper-arm direction
    R_s = quat.frame_from_zy(-u, np.cross(w, v))  # chest <- upper arm

    R_f = R_s @ quat.rot_y(-theta)  # hinge about -y: flexion theta
    axis = -R_f[:, :, 2]  # hand's long axis = forearm direction
    n0 = R_f[:, :, 1] * (1.0 if side == "r" else -1.0)  # neutral palm normal (palm -> body)
    d_avatar = np.array([1.0, 0.0, 0.0]) if palm_dir_avatar is None else palm_dir_avatar
    d_chest = np.einsum("nji,nj->ni", R_c, np.broadcast_to(d_avatar, (n, 3)))
    limit = max(g.ranges[f"{side}_wrist"][1] - TWIST_MARGIN, 0.1)
    limit = min(limit, np.pi - TWIST_MARGIN)
    tau = wrist_twist(axis, n0, quat.normalize(d_chest), limit)
    q_wrist = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), -tau)  # about -z_f by tau

    p_reached = p_avatar_chest + np.einsum(
        "nij,nj->ni", R_c, g.shoulder[side] + d[:, None] * w)
    return ArmIKResult(
        q_shoulder=quat.from_matrix(R_s),
        elbow=theta,
        q_wrist=q_wrist,
        p_reached=p_reached,
        reachable=reachable,
        clamp_distance=np.abs(d_req - d),
    )
