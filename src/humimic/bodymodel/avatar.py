"""Ground truth in the body model's terms: the avatar's torso pose, arm angles in DB's joint
convention, and hand ellipsoids, at any tick (vectorised over ticks).

The avatar's shoulders are ball joints. A shoulder quaternion ``q`` (upper arm relative to the
chest) is decomposed as ``R(q) = Rot(a_SFE, SFE) Rot(a_SAA, SAA) Rot(a_HR, HR)`` with DB's
signed axes (:data:`humimic.bodymodel.kinematics.ARM_AXES`): scipy's intrinsic ``"YXZ"``
Euler angles ``(alpha, beta, gamma)`` give ``SFE = s_SFE alpha``, ``SAA = s_SAA beta``,
``HR = s_HR gamma`` (``s`` the axes' signs). Every rotation has two such decompositions,
``(alpha, beta, gamma)`` and ``(alpha + pi, pi - beta, gamma + pi)``; the one with the smaller
excursion outside the joint limits is kept (an arm raised sideways to 120 deg is SAA = 120 deg,
not SFE = 180, SAA = 60, HR = 180 deg), and of two inside the limits the one with the smaller
sum of squared angles (the nearer to the rest pose). At SAA = +-90 deg (arm horizontal,
sideways) SFE and HR turn about the same axis and only one combination of them is defined
(scipy sets HR = 0): the angles still reproduce the pose exactly but may jump there. The
elbow hinge is DB's EB directly (same axis, -y). The wrist is not a DOF of the model: the hand
is fixed to the forearm, except in Menezes' free hand ellipsoid (:func:`truth_hand_state`).

Torso pose: the chest body's frame (origin at the spine joint) in the reference frame,
``(x, y, z, yaw, pitch, roll)`` as in :mod:`humimic.bodymodel.kinematics`.

``world`` is a :class:`humimic.world.world.World` (uses ``world.gt.qpos``, ``world.scene``);
``frame`` is ``"world"``, ``"base"`` (the robot base at t = 0), ``"W"`` or a 4x4
``T_world_ref``.
"""

from __future__ import annotations

import warnings
from functools import cache

import numpy as np
from scipy.spatial.transform import Rotation

from humimic.bodymodel.kinematics import (
    ARM_AXES,
    ARM_DOFS,
    DOF_NAMES,
    SIDES,
    elbow_rotation,
)
from humimic.bodymodel.limits import JointLimits
from humimic.motion import quat
from humimic.motion.avatar import QPOS_SLICES, AvatarGeometry, ball, chest_pose
from humimic.world.names import HUMAN_PREFIX

#: Avatar joint prefix per model side.
_AVATAR_SIDE = {"R": "r", "L": "l"}
ARM_ANGLE_NAMES = ARM_DOFS["R"] + ARM_DOFS["L"]


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def ypr_from_matrix(R: np.ndarray) -> np.ndarray:
    """``(..., 3)`` yaw, pitch, roll with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (scipy's ``ZYX``
    angles: in closed form away from gimbal lock, ~20x faster for one matrix; scipy there)."""
    R = np.asarray(R, float)
    if np.all(np.abs(R[..., 2, 0]) < 0.9999):
        return np.stack([np.arctan2(R[..., 1, 0], R[..., 0, 0]), np.arcsin(-R[..., 2, 0]),
                         np.arctan2(R[..., 2, 1], R[..., 2, 2])], axis=-1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # gimbal lock: angles still reproduce R
        return Rotation.from_matrix(R.reshape(-1, 3, 3)).as_euler("ZYX").reshape(
            R.shape[:-2] + (3,))


#: :func:`rotations_from_matrices` skips scipy's validation of rotation matrices whose Gram
#: matrix is the identity to within this (scipy's test: 1e-12 off the diagonal).
ORTHONORMAL_TOL = 1e-13


def rotations_from_matrices(R: np.ndarray) -> Rotation:
    """``Rotation.from_matrix`` of matrices ``(N, 3, 3)``; rotations that are proper and
    orthonormal to :data:`ORTHONORMAL_TOL` (products of rotations: to rounding) go without
    scipy's validation (its determinant and Gram matrix cost ~7x the conversion), which
    passes them unchanged; anything else (NaN, a reflection, a skewed matrix) gets it."""
    g = np.einsum("nij,nkj->nik", R, R) - np.eye(3)
    det = np.einsum("ni,ni->n", R[:, 0], np.cross(R[:, 1], R[:, 2]))
    valid = bool(np.all(np.abs(g) <= ORTHONORMAL_TOL) and np.all(det > 0.0))
    return Rotation.from_matrix(R, assume_valid=valid)


@cache
def _arm_limits(side: str) -> JointLimits:
    """The default limits of arm ``side``'s shoulder DOFs (built once)."""
    return JointLimits.default().subset(ARM_DOFS[side][:3])


def shoulder_angles(R_torso_upper: np.ndarray, side: str,
                    limits: JointLimits | None = None) -> np.ndarray:
    """``(..., 3)`` SFE, SAA, HR (rad) of shoulder rotations ``(..., 3, 3)`` (module doc)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        e = rotations_from_matrices(R_torso_upper.reshape(-1, 3, 3)).as_euler("YXZ")
    signs = np.array([s for _, s in ARM_AXES[side][:3]])
    first = _wrap(e * signs)
    second = _wrap(np.stack([e[:, 0] + np.pi, np.pi - e[:, 1], e[:, 2] + np.pi], -1) * signs)
    lim = _arm_limits(side) if limits is None else limits.subset(ARM_DOFS[side][:3])

    def excess(a):
        return np.sum(np.maximum(lim.lower - a, 0) + np.maximum(a - lim.upper, 0), axis=-1)

    e1, e2 = excess(first), excess(second)
    tie = np.abs(e1 - e2) <= 1e-9
    use_second = np.where(tie, np.sum(second ** 2, -1) < np.sum(first ** 2, -1), e2 < e1)
    out = np.where(use_second[:, None], second, first)
    return out.reshape(R_torso_upper.shape[:-2] + (3,))


def _frame(world, frame) -> np.ndarray:
    if isinstance(frame, str):
        return world.gt.T_world_frame(frame)
    return np.asarray(frame, float)


def _geometry(world) -> AvatarGeometry:
    return AvatarGeometry.from_model(world.scene.model, HUMAN_PREFIX)


def state_from_qpos(qpos: np.ndarray, T_ref_avatar: np.ndarray, geometry: AvatarGeometry,
                    limits: JointLimits | None = None) -> np.ndarray:
    """Full model states ``(T, 14)`` (:data:`DOF_NAMES`) of avatar configurations
    ``qpos (T, 51)``, with the torso pose in the frame ``T_ref_avatar`` maps avatar-frame
    points into."""
    qpos = np.atleast_2d(qpos)
    R_a, p_a = chest_pose(qpos, geometry)
    R = T_ref_avatar[:3, :3] @ R_a
    out = np.empty((len(qpos), len(DOF_NAMES)))
    out[:, :3] = p_a @ T_ref_avatar[:3, :3].T + T_ref_avatar[:3, 3]
    out[:, 3:6] = ypr_from_matrix(R)
    for k, side in enumerate(SIDES):
        s = _AVATAR_SIDE[side]
        j = 6 + 4 * k
        out[:, j:j + 3] = shoulder_angles(quat.to_matrix(ball(qpos, f"{s}_shoulder")), side,
                                          limits)
        out[:, j + 3] = qpos[:, _elbow_index(s)]
    return out


def _elbow_index(s: str) -> int:
    return QPOS_SLICES[f"{s}_elbow"].start


def truth_state(world, tick, frame="base", limits: JointLimits | None = None) -> np.ndarray:
    """The avatar's full model state ``(..., 14)`` at ``tick`` (int or array of physics ticks),
    torso pose in ``frame``."""
    T_ref_avatar = np.linalg.inv(_frame(world, frame)) @ world.scene.T_world_avatar
    ticks = np.atleast_1d(tick)
    out = state_from_qpos(world.gt.qpos[ticks], T_ref_avatar, _geometry(world), limits)
    return out[0] if np.ndim(tick) == 0 else out


def truth_angles(world, tick, limits: JointLimits | None = None) -> np.ndarray:
    """The avatar's arm angles ``(..., 8)``: ``R_SFE R_SAA R_HR R_EB L_SFE L_SAA L_HR L_EB``
    (rad, DB's convention) at ``tick``."""
    return truth_state(world, tick, "world", limits)[..., 6:]


def truth_torso_pose(world, tick, frame="base") -> np.ndarray:
    """The avatar's torso pose ``(..., 6)``: ``x y z`` (m) ``yaw pitch roll`` (rad) in
    ``frame``."""
    return truth_state(world, tick, frame)[..., :6]


def hand_frames(qpos: np.ndarray, geometry: AvatarGeometry, side: str
                ) -> tuple[np.ndarray, np.ndarray]:
    """``R_avatar_hand (T, 3, 3)``, ``p_avatar_wrist (T, 3)``: the avatar's hand body frames
    (wrist included) from configurations ``qpos (T, 51)``."""
    s = _AVATAR_SIDE[side]
    R_c, p_c = chest_pose(np.atleast_2d(qpos), geometry)
    R_u = R_c @ quat.to_matrix(ball(qpos, f"{s}_shoulder"))
    p_e = p_c + R_c @ geometry.shoulder[s] - geometry.upper_arm * R_u[:, :, 2]
    R_f = R_u @ elbow_rotation(side, np.atleast_2d(qpos)[:, _elbow_index(s)])
    p_w = p_e - geometry.forearm * R_f[:, :, 2]
    return R_f @ quat.to_matrix(ball(qpos, f"{s}_wrist")), p_w


def truth_hand_state(world, tick, side: str = "R", frame="base") -> np.ndarray:
    """Menezes' 9-D hand state ``(..., 9)`` of the avatar's hand ellipsoid at ``tick``:
    centre ``x y z`` (m), orientation ``yaw pitch roll`` (rad, as the torso's) and semi-axes
    (m) along the hand frame's x, y, z, in ``frame``
    (:func:`humimic.bodymodel.hand.hand_ellipsoids` inverts it)."""
    T_ref_avatar = np.linalg.inv(_frame(world, frame)) @ world.scene.T_world_avatar
    g = world.scene.model.geom(f"{HUMAN_PREFIX}{_AVATAR_SIDE[side]}_hand")
    qpos = world.gt.qpos[np.atleast_1d(tick)]
    R_h, p_w = hand_frames(qpos, _geometry(world), side)
    R = T_ref_avatar[:3, :3] @ R_h
    centre = (p_w + R_h @ g.pos) @ T_ref_avatar[:3, :3].T + T_ref_avatar[:3, 3]
    axes = np.broadcast_to(g.size, centre.shape)
    out = np.concatenate([centre, ypr_from_matrix(R), axes], axis=-1)
    return out[0] if np.ndim(tick) == 0 else out
