"""Forward kinematics of the upper body, vectorised over particles: the conventions, the
rotations, and :func:`forward_kinematics` in numpy -- the tests' reference for the compiled
:func:`humimic.bodymodel.forward_kernel.segment_frames`, which production calls
(``BodyModel.forward``).

State (:data:`DOF_NAMES`, 14 values, Schmidt et al. sec. 4: torso 3 translations + 3 rotations,
4 per arm)::

    torso_x torso_y torso_z  torso_yaw torso_pitch torso_roll
    R_SFE R_SAA R_HR R_EB    L_SFE L_SAA L_HR L_EB

* Torso pose in a *reference frame* of the caller's choice (world, robot base, a person
  frame...): position (m) of the torso origin and ``R_ref_torso = Rz(yaw) Ry(pitch) Rx(roll)``
  (intrinsic z-y-x, scipy ``from_euler("ZYX", [yaw, pitch, roll])``). Choose a reference frame
  with z up: an upright torso then has pitch and roll near 0, far from the convention's
  singularity at pitch = +-90 deg.
* Torso frame = the avatar's chest frame: origin at the spine joint, x forward (the way the
  person faces), y left, z up. The head is fixed to the torso (Schmidt), the hands to the
  forearms (a fixed wrist).
* Arm angles (rad) in DB's convention (``models/db_humanoid.xml``), so tracked angles map
  straight onto the robot's joints. The upper arm relative to the torso is
  ``R = Rot(a_SFE, SFE) Rot(a_SAA, SAA) Rot(a_HR, HR)`` with the signed axes of
  :data:`ARM_AXES` (right arm: -y, -x, +z; left arm: -y, +x, -z), the forearm relative to the
  upper arm ``Rot(-y, EB)``. Positive SFE = flexion (arm forward/up), SAA = abduction
  (outward), HR = internal rotation, EB = elbow flexion; zero = arm hanging, palm inwards.
  Segments hang along their frame's -z: elbow at ``(0, 0, -upper_arm)`` in the upper-arm
  frame, wrist at ``(0, 0, -forearm)`` in the forearm frame.

Segments (:data:`SEGMENTS`) and the joints at their origins (:data:`JOINT_SEGMENT`) come out
as rotations ``(N, S, 3, 3)`` and positions ``(N, S, 3)`` in the reference frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TORSO_DOFS = ("torso_x", "torso_y", "torso_z", "torso_yaw", "torso_pitch", "torso_roll")
ARM_JOINTS = ("SFE", "SAA", "HR", "EB")
SIDES = ("R", "L")
ARM_DOFS = {side: tuple(f"{side}_{j}" for j in ARM_JOINTS) for side in SIDES}
#: The full state, in order.
DOF_NAMES: tuple[str, ...] = TORSO_DOFS + ARM_DOFS["R"] + ARM_DOFS["L"]
#: Signed joint axes in the parent frame, as in ``models/db_humanoid.xml`` (a test reads them
#: from the file): ``(axis index 0/1/2 = x/y/z, sign)`` for SFE, SAA, HR, EB.
ARM_AXES = {
    "R": ((1, -1.0), (0, -1.0), (2, 1.0), (1, -1.0)),
    "L": ((1, -1.0), (0, 1.0), (2, -1.0), (1, -1.0)),
}
SEGMENTS = ("torso", "head", "r_upper_arm", "r_forearm", "r_hand",
            "l_upper_arm", "l_forearm", "l_hand")
#: Joint name -> segment whose frame origin it is.
JOINT_SEGMENT = {"spine": "torso", "neck": "head",
                 "r_shoulder": "r_upper_arm", "r_elbow": "r_forearm", "r_wrist": "r_hand",
                 "l_shoulder": "l_upper_arm", "l_elbow": "l_forearm", "l_wrist": "l_hand"}


@dataclass(frozen=True)
class Skeleton:
    """Joint offsets (m) of an upper body, in the conventions above."""

    shoulder: dict[str, np.ndarray]
    """Shoulder joint per side ``R``/``L`` in the torso frame."""
    neck: np.ndarray
    """Head frame origin (neck joint) in the torso frame."""
    upper_arm: float
    """Shoulder to elbow."""
    forearm: float
    """Elbow to wrist."""

    def __post_init__(self) -> None:
        for name in ("upper_arm", "forearm"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"skeleton: {name} must be > 0 m, got {getattr(self, name)}")


def axis_rotation(axis: int, angle: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` rotations by ``angle`` (rad, any shape) about the x/y/z axis (0/1/2)."""
    angle = np.asarray(angle, float)
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros(angle.shape + (3, 3))
    i, j = (axis + 1) % 3, (axis + 2) % 3
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., j, i] = s
    R[..., i, j] = -s
    return R


def _matrix(rows) -> np.ndarray:
    """``(..., 3, 3)`` from a 3x3 nested list of equally shaped arrays."""
    out = np.empty(np.shape(rows[0][0]) + (3, 3))
    for i, row in enumerate(rows):
        for j, value in enumerate(row):
            out[..., i, j] = value
    return out


def ypr_matrix(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` (scipy ``from_euler("ZYX", [yaw, pitch, roll])``)."""
    cy, sy = np.cos(yaw), np.sin(yaw)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cr, sr = np.cos(roll), np.sin(roll)
    return _matrix([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                    [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                    [-sp, cp * sr, cp * cr]])


def yxz_matrix(alpha: np.ndarray, beta: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """``Ry(alpha) Rx(beta) Rz(gamma)`` (scipy ``from_euler("YXZ", ...)``), closed form."""
    ca, sa = np.cos(alpha), np.sin(alpha)
    cb, sb = np.cos(beta), np.sin(beta)
    cg, sg = np.cos(gamma), np.sin(gamma)
    return _matrix([[ca * cg + sa * sb * sg, sa * sb * cg - ca * sg, sa * cb],
                    [cb * sg, cb * cg, -sb],
                    [ca * sb * sg - sa * cg, sa * sg + ca * sb * cg, ca * cb]])


def shoulder_rotation(side: str, sfe, saa, hr) -> np.ndarray:
    """``R_torso_upperarm`` ``(..., 3, 3)`` from DB's shoulder angles (rad)."""
    (a0, s0), (a1, s1), (a2, s2) = ARM_AXES[side][:3]
    sfe, saa, hr = (np.asarray(v, float) for v in (sfe, saa, hr))
    if (a0, a1, a2) == (1, 0, 2):                       # DB's y, x, z: closed form
        return yxz_matrix(s0 * sfe, s1 * saa, s2 * hr)
    return axis_rotation(a0, s0 * sfe) @ axis_rotation(a1, s1 * saa) @ axis_rotation(a2, s2 * hr)


def elbow_rotation(side: str, eb) -> np.ndarray:
    """``R_upperarm_forearm`` ``(..., 3, 3)`` from the elbow flexion (rad)."""
    a, s = ARM_AXES[side][3]
    return axis_rotation(a, s * np.asarray(eb, float))


def _shoulders(skeleton: Skeleton) -> np.ndarray:
    """(3, 2) the shoulder joints of :data:`SIDES` as columns."""
    return np.array([skeleton.shoulder[side] for side in SIDES]).T


def _shoulder_rotations(sfe: np.ndarray, saa: np.ndarray, hr: np.ndarray) -> np.ndarray:
    """:func:`shoulder_rotation` of both :data:`SIDES` at once, angles ``(N, 2)``:
    ``(N, 2, 3, 3)``."""
    axes = [tuple(a for a, _ in ARM_AXES[side][:3]) for side in SIDES]
    if all(a == (1, 0, 2) for a in axes):            # DB's y, x, z: closed form, one pass
        sign = np.array([[s for _, s in ARM_AXES[side][:3]] for side in SIDES])   # (2, 3)
        return yxz_matrix(sign[:, 0] * sfe, sign[:, 1] * saa, sign[:, 2] * hr)
    return np.stack([shoulder_rotation(side, sfe[:, k], saa[:, k], hr[:, k])
                     for k, side in enumerate(SIDES)], axis=1)


def _elbow_rotations(eb: np.ndarray) -> np.ndarray:
    """:func:`elbow_rotation` of both :data:`SIDES` at once, flexions ``(N, 2)``."""
    (a0, s0), (a1, s1) = (ARM_AXES[side][3] for side in SIDES)
    if a0 == a1:
        return axis_rotation(a0, np.array([s0, s1]) * eb)
    return np.stack([elbow_rotation(side, eb[:, k]) for k, side in enumerate(SIDES)], axis=1)


def forward_kinematics(q: np.ndarray, skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray]:
    """Segment frames for full states ``q`` ``(N, 14)`` (:data:`DOF_NAMES`).

    Test reference only (closed-form y-x-z shoulders, numpy): production calls the compiled
    :func:`humimic.bodymodel.forward_kernel.segment_frames` (``BodyModel.forward``).

    Returns ``R_ref_seg (N, S, 3, 3)`` and ``p_ref_seg (N, S, 3)`` for :data:`SEGMENTS`
    (the reference frame is the one the torso pose is given in).
    """
    q = np.asarray(q, float)
    if q.ndim != 2 or q.shape[1] != len(DOF_NAMES):
        raise ValueError(f"forward_kinematics: q must be (N, {len(DOF_NAMES)}), got {q.shape}")
    n = len(q)
    R = np.empty((n, len(SEGMENTS), 3, 3))
    p = np.empty((n, len(SEGMENTS), 3))
    R_t = ypr_matrix(q[:, 3], q[:, 4], q[:, 5])
    p_t = q[:, :3]
    R[:, 0], p[:, 0] = R_t, p_t
    R[:, 1], p[:, 1] = R_t, p_t + R_t @ skeleton.neck
    # both arms at once, (N, 2 sides, ...): the upper arms are SEGMENTS[2::3], the forearms
    # [3::3], the hands [4::3]
    arms = q[:, 6:14].reshape(n, 2, 4)
    R_u = R_t[:, None] @ _shoulder_rotations(arms[..., 0], arms[..., 1], arms[..., 2])
    p_u = p_t[:, None] + (R_t @ _shoulders(skeleton)).swapaxes(1, 2)
    R_f = R_u @ _elbow_rotations(arms[..., 3])
    p_f = p_u - skeleton.upper_arm * R_u[..., :, 2]
    R[:, 2::3], p[:, 2::3] = R_u, p_u
    R[:, 3::3], p[:, 3::3] = R_f, p_f
    R[:, 4::3], p[:, 4::3] = R_f, p_f - skeleton.forearm * R_f[..., :, 2]
    return R, p
