"""The body model's forward kinematics, compiled: the one production implementation (behind
:meth:`~humimic.bodymodel.model.BodyModel.forward`, the trackers' likelihoods, the scores).

It computes the segment frames of :mod:`humimic.bodymodel.kinematics`'s conventions in one
compiled loop over particles (the torso's ``Rz(yaw) Ry(pitch) Rx(roll)``, the arm rotations
composed from the signed :data:`~humimic.bodymodel.kinematics.ARM_AXES`, from the scalar
kernels of :mod:`~humimic.bodymodel.geometry_kernels`). The vectorised numpy
:func:`~humimic.bodymodel.kinematics.forward_kinematics` (closed-form y-x-z shoulders) is kept
only as the reference the tests check this against (to ~1e-14); both are tested against
MuJoCo's kinematics of DB and of the avatar. numpy's per-call overhead on ``(N, 8, 3, 3)``
arrays dominated at the trackers' 1-150 particles.
"""

from __future__ import annotations

import numpy as np

from humimic.bodymodel.geometry_kernels import axis_rotation_into, mat3_mul, ypr_into
from humimic.bodymodel.kinematics import ARM_AXES, DOF_NAMES, SIDES, Skeleton
from humimic.maths.jit import njit

_AXES = np.array([[a for a, _ in ARM_AXES[side]] for side in SIDES], np.intp)
_SIGNS = np.array([[s for _, s in ARM_AXES[side]] for side in SIDES], float)


@njit
def _forward_kernel(q, axes, signs, shoulders, neck, upper, fore):
    """Segments in ``SEGMENTS`` order: torso, head, then upper arm, forearm, hand per side."""
    n = q.shape[0]
    R = np.empty((n, 8, 3, 3))
    p = np.empty((n, 8, 3))
    Rt, A, B = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    C, Ru, Rf = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    for s in range(n):
        ypr_into(Rt, q[s, 3], q[s, 4], q[s, 5])
        for r in range(3):
            p[s, 0, r] = q[s, r]
            p[s, 1, r] = q[s, r] + (Rt[r, 0] * neck[0] + Rt[r, 1] * neck[1]
                                    + Rt[r, 2] * neck[2])
        for k in range(2):                               # arms R, L
            b, g = 6 + 4 * k, 2 + 3 * k
            axis_rotation_into(A, axes[k, 0], signs[k, 0] * q[s, b])
            axis_rotation_into(B, axes[k, 1], signs[k, 1] * q[s, b + 1])
            mat3_mul(A, B, C)
            axis_rotation_into(A, axes[k, 2], signs[k, 2] * q[s, b + 2])
            mat3_mul(C, A, B)
            mat3_mul(Rt, B, Ru)
            axis_rotation_into(A, axes[k, 3], signs[k, 3] * q[s, b + 3])
            mat3_mul(Ru, A, Rf)
            for r in range(3):
                for m in range(3):
                    R[s, 0, r, m] = Rt[r, m]             # torso and head
                    R[s, 1, r, m] = Rt[r, m]
                    R[s, g, r, m] = Ru[r, m]
                    R[s, g + 1, r, m] = Rf[r, m]
                    R[s, g + 2, r, m] = Rf[r, m]
                p[s, g, r] = q[s, r] + (Rt[r, 0] * shoulders[k, 0] + Rt[r, 1] * shoulders[k, 1]
                                        + Rt[r, 2] * shoulders[k, 2])
                p[s, g + 1, r] = p[s, g, r] - upper * Ru[r, 2]
                p[s, g + 2, r] = p[s, g + 1, r] - fore * Rf[r, 2]
    return R, p


def skeleton_args(skeleton: Skeleton) -> tuple:
    """The kernel's skeleton arguments (a caller that calls often keeps them:
    ``BodyModel`` does)."""
    return (_AXES, _SIGNS,
            np.ascontiguousarray([skeleton.shoulder[side] for side in SIDES], float),
            np.ascontiguousarray(skeleton.neck, float), float(skeleton.upper_arm),
            float(skeleton.forearm))


def segment_frames(q: np.ndarray, skeleton: Skeleton | tuple) -> tuple[np.ndarray, np.ndarray]:
    """Segment frames for full states ``q (N, 14)`` (:data:`DOF_NAMES`): ``R_ref_seg
    (N, S, 3, 3)`` and ``p_ref_seg (N, S, 3)`` for :data:`SEGMENTS` (the reference frame is
    the one the torso pose is given in). ``skeleton``: a :class:`Skeleton` or its
    :func:`skeleton_args`."""
    q = np.ascontiguousarray(q, float)
    if q.ndim != 2 or q.shape[1] != len(DOF_NAMES):
        raise ValueError(f"forward kinematics: q must be (N, {len(DOF_NAMES)}), got {q.shape}")
    args = skeleton_args(skeleton) if isinstance(skeleton, Skeleton) else skeleton
    return _forward_kernel(q, *args)
