"""Head placement: move the avatar's head centre to a target by a torso lean plus a body shift.

A horizontal head displacement ``delta`` is split: the fraction ``lean`` is produced by leaning
the whole upper body about the pelvis (root ball joint) with the hips counter-rotated, so the
legs stay vertical and the feet flat, and the neck counter-rotated, so the head stays upright
(the gaze stays level, as people keep it); the rest, and any vertical displacement, is produced
by sliding the whole body (root slides). The lean angle is exact for the neck base at height
``h`` above the pelvis (``sin(angle) = lean * |delta| / h``, capped at :data:`MAX_LEAN`); the
root slide then makes the head centre exact, compensating the small drop of a leaning head (the
feet rise by that drop: ``h (1 - cos(angle))``, 5 mm for a 7 degree lean).
"""

from __future__ import annotations

import numpy as np

from humimic.motion import quat
from humimic.motion.avatar import QPOS_SLICES, AvatarGeometry

#: Largest torso lean (rad) used for head placement.
MAX_LEAN = 0.5

#: Joints written by :func:`place_head` (a caller must not set them independently).
HEAD_DRIVEN_JOINTS = ("root_x", "root_y", "root_z", "root_rot", "spine", "neck", "r_hip",
                      "l_hip")


def lean_rotation(delta_xy: np.ndarray, lean: float, g: AvatarGeometry) -> np.ndarray:
    """(N, 3, 3) lean of the upper body about the pelvis moving the neck base by ``lean*delta``."""
    h = float(np.linalg.norm(g.chest + g.neck))
    s = lean * np.asarray(delta_xy, float) / h
    norm = np.linalg.norm(s, axis=-1, keepdims=True)
    s = s * np.minimum(1.0, np.sin(MAX_LEAN) / np.maximum(norm, 1e-12))
    n = np.concatenate([s, np.sqrt(1.0 - np.sum(s * s, axis=-1, keepdims=True))], axis=-1)
    return quat.swing(np.array([0.0, 0.0, 1.0]), n)


def place_head(qpos: np.ndarray, p_avatar_head: np.ndarray, lean: float,
               g: AvatarGeometry) -> np.ndarray:
    """Copy of ``qpos`` (N, 51) with the head centre site at ``p_avatar_head`` (N, 3).

    Writes the joints in :data:`HEAD_DRIVEN_JOINTS` (spine is set to the identity).
    """
    q = np.array(qpos, float)
    p_t = np.broadcast_to(np.asarray(p_avatar_head, float), (len(q), 3))
    delta = p_t - g.head_zero
    R_lean = lean_rotation(delta[:, :2], lean, g)
    q_lean = quat.from_matrix(R_lean)
    q_back = quat.conj(q_lean)
    q[:, QPOS_SLICES["root_rot"]] = q_lean
    q[:, QPOS_SLICES["spine"]] = [1.0, 0.0, 0.0, 0.0]
    q[:, QPOS_SLICES["neck"]] = q_back
    q[:, QPOS_SLICES["r_hip"]] = q_back
    q[:, QPOS_SLICES["l_hip"]] = q_back
    p_head_leaned = g.pelvis + R_lean @ (g.chest + g.neck) + g.head_site
    q[:, 0:3] = p_t - p_head_leaned
    return q
