"""Vectorised rotation helpers in MuJoCo's conventions.

Quaternions are ``[w, x, y, z]`` (scalar first, as MuJoCo's ``qpos`` of a ball joint), unit,
Hamilton product. Every function broadcasts over leading dimensions: ``q`` is ``(..., 4)``, a
rotation matrix ``(..., 3, 3)``, a vector ``(..., 3)``. ``R @ v`` maps child to parent
coordinates, like MuJoCo's ``xmat``.
"""

from __future__ import annotations

import numpy as np


def mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b``."""
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
    """Rotation matrix of a unit quaternion."""
    w, x, y, z = np.moveaxis(normalize(q), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (``w >= 0``) of a rotation matrix (Shepperd's method, batch-safe)."""
    R = np.asarray(R, float)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    # Four candidate solutions; pick per element the one with the largest pivot.
    cand = np.stack(
        [
            np.stack([1 + m00 + m11 + m22, R[..., 2, 1] - R[..., 1, 2],
                      R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1),
            np.stack([R[..., 2, 1] - R[..., 1, 2], 1 + m00 - m11 - m22,
                      R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0]], -1),
            np.stack([R[..., 0, 2] - R[..., 2, 0], R[..., 0, 1] + R[..., 1, 0],
                      1 - m00 + m11 - m22, R[..., 1, 2] + R[..., 2, 1]], -1),
            np.stack([R[..., 1, 0] - R[..., 0, 1], R[..., 0, 2] + R[..., 2, 0],
                      R[..., 1, 2] + R[..., 2, 1], 1 - m00 - m11 + m22], -1),
        ],
        axis=-2,
    )  # (..., 4 candidates, 4)
    pivots = np.stack([1 + m00 + m11 + m22, 1 + m00 - m11 - m22,
                       1 - m00 + m11 - m22, 1 - m00 - m11 + m22], -1)
    best = np.argmax(pivots, axis=-1)
    q = np.take_along_axis(cand, best[..., None, None], axis=-2)[..., 0, :]
    q = normalize(q)
    return np.where(q[..., :1] < 0, -q, q)


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternion of a rotation by ``angle`` (rad) about the unit ``axis``."""
    angle = np.asarray(angle, float)[..., None]
    axis = normalize(axis)
    return np.concatenate([np.cos(angle / 2), np.sin(angle / 2) * axis], axis=-1)


def from_rotvec(r: np.ndarray) -> np.ndarray:
    """Quaternion of a rotation vector (axis * angle, rad); smooth through zero."""
    r = np.asarray(r, float)
    th = np.linalg.norm(r, axis=-1, keepdims=True)
    # sin(th/2)/th, with its Taylor series near zero.
    k = np.where(th > 1e-8, np.sin(th / 2) / np.where(th > 1e-8, th, 1.0), 0.5 - th**2 / 48)
    return np.concatenate([np.cos(th / 2), k * r], axis=-1)


def to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle, angle in [0, pi]) of a unit quaternion."""
    q = normalize(q)
    q = np.where(q[..., :1] < 0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    th = 2 * np.arctan2(s, q[..., :1])
    k = np.where(s > 1e-12, th / np.where(s > 1e-12, s, 1.0), 2.0)
    return k * q[..., 1:]


def angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle in [0, pi] of a unit quaternion (what MuJoCo's ball-joint range limits)."""
    q = normalize(q)
    return 2 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), np.abs(q[..., 0]))


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R(q) v``."""
    return np.einsum("...ij,...j->...i", to_matrix(q), v)


def rot_x(a: np.ndarray) -> np.ndarray:
    """Rotation matrices about x by angles ``a`` (rad)."""
    return _elementary(a, 0)


def rot_y(a: np.ndarray) -> np.ndarray:
    """Rotation matrices about y by angles ``a`` (rad)."""
    return _elementary(a, 1)


def rot_z(a: np.ndarray) -> np.ndarray:
    """Rotation matrices about z by angles ``a`` (rad)."""
    return _elementary(a, 2)


def _elementary(a: np.ndarray, axis: int) -> np.ndarray:
    a = np.asarray(a, float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i, j = (axis + 1) % 3, (axis + 2) % 3  # cyclic: x->(y,z), y->(z,x), z->(x,y)
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def swing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Minimal rotation matrix taking unit ``a`` onto unit ``b`` (not antiparallel)."""
    a, b = normalize(a), normalize(b)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)[..., None, None]
    K = np.zeros(v.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    return np.eye(3) + K + (K @ K) / (1.0 + c)


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
