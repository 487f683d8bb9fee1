"""Menezes et al.'s free hand ellipsoid (sec. 6.1.2, eq. 16): the 9-D state
``(t_x, t_y, t_z, alpha, beta, gamma, sigma_x, sigma_y, sigma_z)`` = centre (m), orientation
and semi-axes (m) along the hand frame's x, y, z. The orientation is ``yaw pitch roll`` (rad),
``R_ref_hand = Rz(yaw) Ry(pitch) Rx(roll)``, as the torso's
(:mod:`humimic.bodymodel.kinematics`); the paper does not say which Euler convention it used.

Project with :func:`humimic.bodymodel.projection.project_ellipsoids`::

    R, t, axes = hand_ellipsoids(states)                       # states (N, 9), ref frame
    R_cam, t_cam = to_camera(T_cam_ref, R, t)
    outline, quadric, conic = project_ellipsoids(R_cam, t_cam, axes, intrinsics, 16)
"""

from __future__ import annotations

import numpy as np

from humimic.bodymodel.kinematics import ypr_matrix

HAND_STATE = ("x", "y", "z", "yaw", "pitch", "roll", "sigma_x", "sigma_y", "sigma_z")


def check_hand_states(state: np.ndarray) -> None:
    """Raise ValueError unless ``state (N, 9)`` are hand states with positive semi-axes."""
    if state.shape[-1] != len(HAND_STATE):
        raise ValueError(f"hand state must have {len(HAND_STATE)} values "
                         f"({', '.join(HAND_STATE)}), got {state.shape[-1]}")
    if len(state) and state[:, 6:].min() <= 0.0:         # (np.any's dispatch: 3x the cost)
        raise ValueError("hand state: semi-axes sigma_x, sigma_y, sigma_z must be > 0 m")


def hand_ellipsoids(state: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``R_ref_hand (N, 3, 3)``, centres ``(N, 3)`` and semi-axes ``(N, 3)`` of 9-D hand states
    ``(N, 9)``. Semi-axes must be positive (a tracker keeps them so, e.g. by clamping)."""
    state = np.atleast_2d(np.asarray(state, float))
    check_hand_states(state)
    return ypr_matrix(state[:, 3], state[:, 4], state[:, 5]), state[:, :3], state[:, 6:]


def to_camera(T_cam_ref: np.ndarray, R: np.ndarray, t: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """Poses ``(R (..., 3, 3), t (..., 3))`` from the reference frame into the camera."""
    T = np.asarray(T_cam_ref, float)
    return T[:3, :3] @ R, t @ T[:3, :3].T + T[:3, 3]
