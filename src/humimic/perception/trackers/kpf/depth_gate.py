"""A foreshortening gate on the kept wrist range (our extension of Schmidt et al.'s kernel
particle filter, ``KpfConfig.keep_range_gate_deg``).

:func:`~humimic.perception.trackers.kpf.depth.kept_ranges` puts propagated wrists back at their
ancestor's camera distance: right for an arm near the image plane, whose image hardly changes
with its depth (a segment tilted by theta out of the plane normal to the viewing ray projects
to ``cos(theta)`` of its length: ``1 - theta^2 / 2``, second order), wrong for an arm pointing
towards the camera, whose image shortens to first order (``d cos / d theta = -sin theta``) so
the likelihood does judge its depth. The gate makes the share of kept ranges a function of
the arm's (shoulder -> wrist) angle out of the image plane: all kept below ``lo``, none above
``hi``, a smooth step between.

Measured, it does not help (``KpfConfig.keep_range_gate_deg``): the gate is local, the error
is not. The tracker's depth error is a kinematic flip (the arm pose with the same elbow and
wrist images, :mod:`~humimic.perception.trackers.kpf.flips`), and the two poses of a flip pair
lie on opposite sides of the gate. Table 1's camera sees the hanging and the side-pointing arm
tilted ~13 deg away from the camera (the angle about the ray through the arm's middle; the
wrist's range a constant 2.11 m), the arm pointing at 45 deg ~32 deg towards it (range 1.70
m). The angular arm's flip is the side-like pose (+14 deg): held, so the estimate stays in it
for the whole hold; the side arm's flip is the angular-like pose (-32 deg): once a slow drift
carries the estimate past ``lo`` it is free and falls into it.
"""

from __future__ import annotations

import numpy as np

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.depth import SIDES


def out_of_plane_angle(p_a: np.ndarray, p_b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``(N,)`` the angle (rad, in [0, pi/2]) between the segments ``p_a -> p_b`` ``(N, 3)`` and
    the plane normal to the camera ray from the centre ``c (3,)`` through their midpoints:
    ``arcsin(|d . u|)`` for the unit segment direction ``d`` and ray ``u``. The segment's
    image (locally, a short segment) is ``cos`` of it times the length it would have in that
    plane."""
    p_a, p_b = np.atleast_2d(np.asarray(p_a, float)), np.atleast_2d(np.asarray(p_b, float))
    d = p_b - p_a
    u = 0.5 * (p_a + p_b) - np.asarray(c, float)
    s = np.abs(np.sum(d * u, axis=1)) / (np.linalg.norm(d, axis=1) * np.linalg.norm(u, axis=1))
    return np.arcsin(np.clip(s, 0.0, 1.0))


def hold_share(theta: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The gate: 1 for ``theta <= lo``, 0 for ``theta >= hi`` (rad), between them ``1 - (3 t^2
    - 2 t^3)`` of ``t = (theta - lo) / (hi - lo)`` (a smooth step, flat at both ends)."""
    t = np.clip((np.asarray(theta, float) - lo) / (hi - lo), 0.0, 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t)


def arm_hold_shares(body: bm.BodyModel, q: np.ndarray, c_ref: np.ndarray, lo: float, hi: float
                    ) -> dict[str, np.ndarray]:
    """Per arm side (``R``, ``L``), ``(N,)`` the gate (:func:`hold_share`) of states ``q (N, 14)``
    from their shoulder -> wrist angle out of the image plane (camera centre ``c_ref``,
    reference frame)."""
    pose = body.forward(np.atleast_2d(np.asarray(q, float)))
    return {s: hold_share(out_of_plane_angle(pose.joint(f"{p}_shoulder"), pose.joint(f"{p}_wrist"),
                                             c_ref), lo, hi)
            for s, (p, _) in SIDES.items()}


def keep_range_gates(body: bm.BodyModel, cfg, pred: np.ndarray, T_cam_ref: np.ndarray
                     ) -> dict[str, np.ndarray] | None:
    """The gates of ``KpfConfig`` ``cfg``'s kept ranges from the propagated particles ``pred``
    ``(N, 14)`` (None without ``keep_range_gate_deg``)."""
    if cfg.keep_range_gate_deg is None:
        return None
    c = np.linalg.inv(np.asarray(T_cam_ref, float))[:3, 3]
    return arm_hold_shares(body, pred, c, *np.radians(cfg.keep_range_gate_deg))
