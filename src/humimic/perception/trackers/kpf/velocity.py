"""The motion model's velocity restricted to what the image sees (our extension of Schmidt sec.
5.2's linear motion model, ``KpfConfig.observed_velocity_px``).

Schmidt sec. 5.2: "The velocity in the linear motion model is estimated on the basis of the
location of the best mode in time t and its corresponding location in time t - 1"; a share of
the particles is propagated by it. One camera pins an arm only up to the directions of its
joint space that move its image; along the others (the wrist's depth when the arm lies near
the image plane, the humeral rotation of a straight arm) the best mode jitters from frame to
frame, and that jitter, fed forward as velocity, pushes the arm along exactly the directions
the likelihood cannot pull it back from. :func:`observable_velocity` keeps of an arm's velocity
``v`` (rad per frame) only what moves its projected elbow and wrist: with the image Jacobian
``J = U diag(s) V^T`` (px / rad, :func:`arm_image_jacobian`), the damped least-squares
projection ``V diag(s^2 / (s^2 + lambda^2)) V^T v`` (Tikhonov; ``lambda`` in px / rad), which
passes components whose image motion ``s`` is well above ``lambda`` and drops those well below.
Measured (``KpfConfig.observed_velocity_px``): the image fit improves but the depth error grows
on side pointing (the true rise has components along the weak directions too); off.

:func:`noise_shaping` does the same to the propagation's random noise
(``KpfConfig.observed_walk_px``): ``floor I + (1 - floor) P`` with ``P`` the damped projection
above, the noise's extent kept along directions that move the image and shrunk to ``floor``
along those that do not.
"""

from __future__ import annotations

import numpy as np

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.depth import SIDES

#: The arm points whose images pin the arm's four DOFs (two image points, four coordinates).
ARM_POINTS = ("elbow", "wrist")


def particle_velocities(parts: np.ndarray, resampled: np.ndarray, walked: np.ndarray,
                        velocity: np.ndarray, moved: np.ndarray, innovation: bool,
                        decay: float = 1.0) -> np.ndarray:
    """``(N, d)`` each particle's velocity for the next frame's linear motion model
    (``KpfConfig.particle_velocity``), times ``decay``: ``innovation=False``, its whole
    displacement this frame, ``parts - resampled`` (ancestor -> where mean shift took it: the
    propagation noise included); ``innovation=True``, the motion model's velocity it was
    propagated with (``velocity``, ``(d,)`` or ``(N, d)``, for the ``moved`` ones; zero for
    the random group) plus the mean-shift correction ``parts - walked`` (``walked`` the
    propagated particles), i.e. the displacement without the injected noise (an alpha-beta
    filter's velocity update, gain 1: along directions the likelihood does not pull, the
    velocity does not random-walk with the noise)."""
    parts, resampled = np.asarray(parts, float), np.asarray(resampled, float)
    if not innovation:
        return decay * (parts - resampled)
    used = np.where(np.asarray(moved, bool)[:, None], np.broadcast_to(velocity, parts.shape),
                    0.0)
    return decay * (used + parts - np.asarray(walked, float))


def observable_velocity(v: np.ndarray, J: np.ndarray, lam: float) -> np.ndarray:
    """``V diag(s^2 / (s^2 + lam^2)) V^T v`` for ``J = U diag(s) V^T`` (``J (m, d)`` the image
    Jacobian, ``v (d,)`` the velocity, or ``(N, d)`` row-wise): the damped pseudo-inverse
    ``(J^T J + lam^2 I)^-1 J^T J`` applied to ``v``, i.e. ``v``'s components along the right
    singular vectors scaled by ``s^2 / (s^2 + lam^2)``; right singular directions beyond ``m``
    (``s = 0``) dropped."""
    v, J = np.asarray(v, float), np.asarray(J, float)
    _, s, Vt = np.linalg.svd(J, full_matrices=False)
    keep = s * s / (s * s + lam * lam)
    return ((v @ Vt.T) * keep) @ Vt


def noise_shaping(J: np.ndarray, lam: float, floor: float) -> np.ndarray:
    """``(d, d)`` ``V diag(floor + (1 - floor) s^2 / (s^2 + lam^2)) V^T`` for ``J (m, d) =
    U diag(s) V^T`` (right singular directions beyond ``m``: ``s = 0``, factor ``floor``): the
    matrix that scales noise along each joint-space singular direction of ``J`` by a factor
    near 1 where the direction moves the image (``s >> lam``) and near ``floor`` where it does
    not. ``floor I + (1 - floor)`` times :func:`observable_velocity`'s projection (symmetric)."""
    d = np.asarray(J).shape[1]
    return floor * np.eye(d) + (1.0 - floor) * observable_velocity(np.eye(d), J, lam)


def arm_noise_shaping(body: bm.BodyModel, intr, q: np.ndarray, T_cam_ref: np.ndarray,
                      lam: float, floor: float) -> np.ndarray:
    """``(14, 14)`` block-diagonal noise shaping (:func:`noise_shaping`) of the state: each
    arm's block through its :func:`arm_image_jacobian` at ``q``, the torso's the identity; an
    arm whose Jacobian is not finite (a point behind the camera) keeps the identity."""
    A = np.eye(len(q))
    for side, (_, j) in SIDES.items():
        J = arm_image_jacobian(body, intr, q, side, T_cam_ref)
        if np.all(np.isfinite(J)):
            A[j:j + 4, j:j + 4] = noise_shaping(J, lam, floor)
    return A


def arm_image_jacobian(body: bm.BodyModel, intr, q: np.ndarray, side: str,
                       T_cam_ref: np.ndarray, eps: float = 1e-4) -> np.ndarray:
    """``(4, 4)`` d(elbow u, v, wrist u, v) / d(SFE, SAA, HR, EB) (px / rad) of arm ``side``
    (``R`` or ``L``) at state ``q (14,)`` seen by a camera (``T_cam_ref``: reference-frame
    points -> camera, ``intr`` its intrinsics): central differences of the body model's forward
    kinematics and the camera's projection. NaN where a point is behind the camera."""
    prefix, j = SIDES[side]
    q = np.asarray(q, float)
    Q = np.repeat(q[None], 8, axis=0)
    for k in range(4):
        Q[2 * k, j + k] += eps
        Q[2 * k + 1, j + k] -= eps
    pose = body.forward(Q)
    T = np.asarray(T_cam_ref, float)
    uv = np.concatenate([intr.project(pose.joint(f"{prefix}_{p}") @ T[:3, :3].T + T[:3, 3])
                         for p in ARM_POINTS], axis=1)               # (8, 4)
    return ((uv[0::2] - uv[1::2]) / (2.0 * eps)).T


def observable_arm_velocity(body: bm.BodyModel, intr, q: np.ndarray, v: np.ndarray,
                            T_cam_ref: np.ndarray, lam: float) -> np.ndarray:
    """The motion model's velocity ``v (14,)`` (or one per particle, ``(N, 14)``) with each
    arm's part restricted by :func:`observable_velocity` through its :func:`arm_image_jacobian`
    at ``q`` (the last best mode); the torso's part unchanged. An arm whose Jacobian is not
    finite (a point behind the camera) keeps its velocity."""
    out = np.asarray(v, float).copy()
    for side, (_, j) in SIDES.items():
        J = arm_image_jacobian(body, intr, q, side, T_cam_ref)
        if np.all(np.isfinite(J)):
            out[..., j:j + 4] = observable_velocity(out[..., j:j + 4], J, lam)
    return out
