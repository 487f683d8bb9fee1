"""Skin-blob importance samples for TBP's arms: automatic (re-)initialisation.

TBP's dynamics only search near where the arms were. A person who already has a hand raised
when tracking starts (the filter starts at the rest pose), or who raises it faster than the
particles can follow, leaves the filter with no particle near the true arm: the skin cue of
the first stage then has nothing to pick. As ICONDENSATION does with its importance function
(Menezes sec. 4.2, here per arm), every frame a fraction of the particles gets one arm's four
angles drawn from arm configurations whose hand projects onto a skin blob of the image:

* :func:`arm_table` -- ``M`` arm configurations drawn uniformly in the joint limits, once, with
  each hand's centre in the torso segment's frame (the arm chain hangs off the torso, so a
  rigid transform places the table for any torso pose);
* :func:`hand_pixels` -- the table's hands in the image for this frame's torso;
* :func:`near_blobs` -- which configurations put a hand within a radius of a blob centre.

The drawn configurations cover every depth along the blob's line of sight (one eye cannot
tell); the full likelihood (eq. 19) weights them like any other particle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.bodymodel.model import BodyModel, Pose
from humimic.sensors.camera_model import Intrinsics

SIDES = ("r", "l")


@dataclass(frozen=True)
class ArmTable:
    q: np.ndarray
    """(M, 8) arm angles (``R_SFE ... L_EB``), uniform in the limits."""
    p_torso_hand: np.ndarray
    """(2, M, 3) right and left hand centres in the torso segment frame (m)."""


def hand_centres(body: BodyModel, pose: Pose) -> np.ndarray:
    """``(2, N, 3)`` the right and left hand parts' centres of a pose (reference frame)."""
    out = []
    for s in SIDES:
        part = body.part(f"{s}_hand")
        R, p = pose.segment(part.segment)
        out.append(p + R @ part.p_seg_part)
    return np.stack(out)


def arm_table(body: BodyModel, n: int, rng: np.random.Generator) -> ArmTable:
    """``n`` configurations of both arms uniform in ``body``'s free limits (the 8 arm DOFs)
    and their hands in the torso segment frame."""
    lim = body.free_limits
    q = rng.uniform(lim.lower, lim.upper, (n, len(lim.lower)))
    pose = body.forward(q)
    R_t, p_t = pose.segment("torso")
    hands = hand_centres(body, pose)                                     # (2, n, 3)
    local = np.einsum("nji,snj->sni", R_t, hands - p_t[None])            # R^T (p - p_t)
    return ArmTable(q, local)


def hand_pixels(table: ArmTable, R_base_torso: np.ndarray, p_base_torso: np.ndarray,
                intrinsics: Intrinsics, T_cam_base: np.ndarray) -> np.ndarray:
    """``(2, M, 2)`` pixels of the table's hands with the torso segment at ``R_base_torso``,
    ``p_base_torso`` (NaN behind the camera)."""
    p_base = table.p_torso_hand @ R_base_torso.T + p_base_torso
    return intrinsics.project(p_base @ T_cam_base[:3, :3].T + T_cam_base[:3, 3])


def near_blobs(uv: np.ndarray, centres: np.ndarray, radius: np.ndarray) -> list[np.ndarray]:
    """For each blob ``k`` (centre ``centres[k]``, radius ``radius[k]`` px), the indices of the
    points ``uv (M, 2)`` within the radius."""
    d2 = np.sum((uv[None] - centres[:, None]) ** 2, axis=-1)            # (K, M)
    return [np.flatnonzero(row <= r * r) for row, r in zip(d2, radius, strict=True)]


def head_circle(body: BodyModel, pose: Pose, intrinsics: Intrinsics,
                T_cam_base: np.ndarray) -> tuple[np.ndarray, float]:
    """The head's image centre (px) and radius (px, its largest semi-axis at its depth) of
    the first particle of ``pose``: skin blobs there are the face, not a hand."""
    part = body.part("head")
    R, p = pose.segment(part.segment)
    p_cam = T_cam_base[:3, :3] @ (p[0] + R[0] @ part.p_seg_part) + T_cam_base[:3, 3]
    radius = intrinsics.fx * float(np.max(part.shape.semi_axes)) / p_cam[2]
    return intrinsics.project(p_cam), radius


def draw_arms(particles: np.ndarray, table: ArmTable, groups: list[tuple[int, np.ndarray]],
              n: int, sigma: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``n`` of the ``[q_k, q_{k-1}]`` ``particles (N, 16)`` (drawn without replacement) get
    one arm from the table: a group ``(side 0/1, table indices)`` is drawn uniformly, then a
    configuration in it, plus ``sigma`` (rad) of noise; the arm starts at rest (``q_{k-1} =
    q_k``). Returns the new particles and the replaced indices."""
    x = particles.copy()
    idx = rng.choice(len(x), size=min(n, len(x)), replace=False)
    g = rng.integers(len(groups), size=len(idx))
    for i, gi in zip(idx, g, strict=True):
        side, members = groups[gi]
        cols = np.arange(4) + 4 * side
        q = table.q[rng.choice(members), cols] + rng.normal(0.0, sigma, 4)
        x[i, cols] = q
        x[i, cols + 8] = q
    return x, idx


__all__ = ["ArmTable", "arm_table", "draw_arms", "hand_centres", "hand_pixels", "head_circle",
           "near_blobs"]
