"""Our extension (issue 14, ``KpfConfig.velocity_gate_px``): an arm's motion-model velocity
kept only while its image moves.

Monocular angular pointing's depth is chosen where the arm passes a kinematic branch point
(its elbow's or wrist's camera ray tangent to the bone's sphere, where the arm's mirrors meet,
:mod:`~humimic.perception.trackers.kpf.flips`): the likelihood scores both continuations alike,
and only momentum carries a particle through onto the true branch (``particle_velocity``).
The same momentum, fed forward while the arm holds still, drifts the unobserved depth. Here
an arm's velocity is used while its best mode's projected elbow or wrist moved at least
``gate_px`` between the last two frames (:func:`arm_image_motion`), and zeroed for the arm
otherwise: a still image is, but for a rare motion exactly along the camera rays, a still arm.
"""

from __future__ import annotations

import numpy as np

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.depth import SIDES
from humimic.perception.trackers.kpf.velocity import ARM_POINTS


def arm_image_motion(body: bm.BodyModel, intr, q: np.ndarray, q_prev: np.ndarray, side: str,
                     T_cam_ref: np.ndarray) -> float:
    """The largest image displacement (px) of arm ``side``'s elbow and wrist between states
    ``q_prev`` and ``q`` ``(14,)``, both seen by one camera (``T_cam_ref``: reference-frame
    points -> camera); NaN where a point is behind the camera."""
    prefix, _ = SIDES[side]
    pose = body.forward(np.stack([q, q_prev]))
    T = np.asarray(T_cam_ref, float)
    d = [np.linalg.norm(np.subtract(*intr.project(pose.joint(f"{prefix}_{p}") @ T[:3, :3].T
                                                   + T[:3, 3])))
         for p in ARM_POINTS]
    return float(np.max(d))


def gated_velocity(body: bm.BodyModel, intr, q: np.ndarray, q_prev: np.ndarray,
                   velocity: np.ndarray, T_cam_ref: np.ndarray, gate_px: float) -> np.ndarray:
    """The motion model's ``velocity`` ``(14,)`` or per particle ``(N, 14)`` with the DOFs of
    each arm whose :func:`arm_image_motion` from ``q_prev`` to ``q`` is below ``gate_px`` set
    to zero (an arm with a point behind the camera keeps its velocity); the torso's unchanged."""
    out = np.array(velocity, float, copy=True)
    for side, (_, j) in SIDES.items():
        if arm_image_motion(body, intr, q, q_prev, side, T_cam_ref) < gate_px:
            out[..., j:j + 4] = 0.0
    return out
