"""Rotation helpers in MuJoCo's conventions, on scipy's :class:`Rotation`.

Quaternions are ``[w, x, y, z]`` (scalar first, as MuJoCo's ``qpos`` of a ball joint), unit,
Hamilton product. Every function broadcasts over leading dimensions: ``q`` is ``(..., 4)``, a
rotation matrix ``(..., 3, 3)``, a vector ``(..., 3)``. ``R @ v`` maps child to parent
coordinates, like MuJoCo's ``xmat``. Conversions are scipy's (``scalar_first=True``); what
scipy does not offer stays here: the product of non-unit quaternions (:func:`mul`, for
quaternion derivatives), the swing between two vectors, a frame from two axes and sign
continuity along a trajectory.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def _rot(q: np.ndarray) -> tuple[Rotation, tuple[int, ...]]:
    q = np.array(q, float)  # scipy needs a writable array
    return Rotation.from_quat(q.reshape(-1, 4), scalar_first=True), q.shape[:-1]


def mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` of any quaternions (also derivatives, which are not
    rotations: scipy's ``Rotation`` would normalise them)."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, float), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, float), -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def conj(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion)."""
    q = np.asarray(q, float)
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def normalize(v: np.ndarray, eps: float = 1e-12) -> np.ndarray:
    """``v / |v|`` along the last axis (zero vectors stay zero)."""
    v = np.asarray(v, float)
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, eps)


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a quaternion (normalised first)."""
    r, shape = _rot(q)
    return r.as_matrix().reshape(shape + (3, 3))


def from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (``w >= 0``) of a rotation matrix."""
    R = np.array(R, float)
    q = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat(canonical=True, scalar_first=True)
    return q.reshape(R.shape[:-2] + (4,))


def from_rotvec(r: np.ndarray) -> np.ndarray:
    """Quaternion of a rotation vector (axis * angle, rad)."""
    r = np.array(r, float)  # scipy needs a writable array
    return Rotation.from_rotvec(r.reshape(-1, 3)).as_quat(scalar_first=True).reshape(
        r.shape[:-1] + (4,))


def to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle, angle in [0, pi]) of a quaternion."""
    r, shape = _rot(q)
    return r.as_rotvec().reshape(shape + (3,))


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternion of a rotation by ``angle`` (rad) about the unit ``axis``."""
    return from_rotvec(normalize(axis) * np.asarray(angle, float)[..., None])


def angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle in [0, pi] of a quaternion (what MuJoCo's ball-joint range limits)."""
    r, shape = _rot(q)
    return r.magnitude().reshape(shape)


def rot_x(a: np.ndarray) -> np.ndarray:
    """Rotation matrices about x by angles ``a`` (rad)."""
    return _elementary(a, "x")


def rot_y(a: np.ndarray) -> np.ndarray:
    """Rotation matrices about y by angles ``a`` (rad)."""
    return _elementary(a, "y")


def rot_z(a: np.ndarray) -> np.ndarray:
    """Rotation matrices about z by angles ``a`` (rad)."""
    return _elementary(a, "z")


def _elementary(a: np.ndarray, axis: str) -> np.ndarray:
    a = np.array(a, float)
    return Rotation.from_euler(axis, a.reshape(-1, 1)).as_matrix().reshape(a.shape + (3, 3))


def swing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Minimal rotation matrix taking unit ``a`` onto unit ``b`` (not antiparallel)."""
    a, b = normalize(a), normalize(b)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)[..., None, None]
    K = np.zeros(v.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    return np.eye(3) + K + (K @ K) / (1.0 + c)


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Angle (rad, in [0, pi]) of rotation matrices ``R`` (..., 3, 3):
    ``arccos((trace R - 1) / 2)``."""
    tr = np.trace(R, axis1=-2, axis2=-1)
    return np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0))


def twist_angle(R: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Angle (rad, in [-pi, pi]) of the twist of rotation matrices ``R`` (..., 3, 3) about the
    unit ``axis`` (..., 3) in their swing-twist decomposition ``R = R_swing R_twist`` (``R_swing``
    about an axis orthogonal to ``axis``): ``2 atan2(v . axis, w)`` of ``R``'s quaternion."""
    q = from_matrix(R)
    a = 2.0 * np.arctan2(np.sum(q[..., 1:] * axis, axis=-1), q[..., 0])
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def hemisphere_continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs along axis 0 so that consecutive quaternions have a non-negative dot product."""
    q = np.array(q, float)
    if len(q) < 2:
        return q
    dots = np.sum(q[1:] * q[:-1], axis=-1)
    flips = np.cumprod(np.where(dots < 0, -1.0, 1.0), axis=0)
    q[1:] *= flips[..., None]
    return q


def frame_from_zy(z: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Rotation whose z column is ``z`` and whose y column is ``y`` made orthogonal to ``z``."""
    z = normalize(z)
    y = normalize(y - np.sum(y * z, axis=-1, keepdims=True) * z)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-1)
