"""A depth-aware proposal for the arms (our extension of Schmidt et al.'s kernel particle filter).

One camera sees a wrist only up to its distance along the viewing ray: most of the tracker's
error is in depth. :func:`wrist_depth_move` moves an arm's wrist along the camera ray through
it by a range change ``delta`` (m) and re-solves the arm for the new wrist: the elbow flexion
from the shoulder-wrist distance (law of cosines), the upper arm turned by the smallest
rotation that takes the wrist there (keeping the arm's swivel about the shoulder-wrist line as
far as possible), and the shoulder angles from that rotation. The wrist's image stays put while
the arm changes its depth, so the likelihood can choose between depths a random walk in joint
space would rarely reach in one frame. :func:`keep_wrist_range` uses the same move the other
way round (``KpfConfig.keep_range_share``): a propagated wrist put back at a reference camera
distance on its new ray, so that the propagation moves the arm across the ray and not along it.
"""

from __future__ import annotations

import numpy as np

from humimic import bodymodel as bm
from humimic.bodymodel.kinematics import elbow_rotation
from humimic.maths.rotations import rotation_between
from humimic.perception.trackers.kpf.depth_kernel import kept_range_rows

#: Arm side -> (segment prefix, offset of its four DOFs in the state).
SIDES = {"R": ("r", 6), "L": ("l", 10)}


def wrist_depth_move(body: bm.BodyModel, q: np.ndarray, side: str, delta: np.ndarray,
                     T_cam_ref: np.ndarray, pose: bm.Pose | None = None,
                     T_ref_cam: np.ndarray | None = None) -> np.ndarray:
    """States ``(N, 14)`` with arm ``side`` (``R`` or ``L``) of ``q (N, 14)`` re-solved for its
    wrist moved by ``delta (N,)`` m along the ray from the camera (``T_cam_ref``: reference-
    frame points -> camera) through it. Where the new wrist is out of the arm's reach, or
    the solution out of the joint limits, the particle is left unchanged. ``pose``: ``q``'s
    forward kinematics (or any pose with the same torso and arm ``side``), ``T_ref_cam``
    ``T_cam_ref``'s inverse, if the caller has them."""
    q = np.asarray(q, float)
    prefix, j = SIDES[side]
    sk = body.skeleton
    lu, lf = sk.upper_arm, sk.forearm
    pose = body.forward(q) if pose is None else pose
    S, W = pose.joint(f"{prefix}_shoulder"), pose.joint(f"{prefix}_wrist")
    if T_ref_cam is None:
        T_ref_cam = np.linalg.inv(np.asarray(T_cam_ref, float))
    ray = W - T_ref_cam[:3, 3]
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    d_new = W + np.asarray(delta, float)[:, None] * ray - S            # shoulder -> new wrist
    r = np.linalg.norm(d_new, axis=1)
    ok = (r < lu + lf - 1e-6) & (r > abs(lu - lf) + 1e-6)
    eb = np.arccos(np.clip((r * r - lu * lu - lf * lf) / (2 * lu * lf), -1.0, 1.0))
    # the shoulder -> wrist vector in the upper arm's frame for the new elbow flexion
    d_local = np.array([0.0, 0.0, -lu]) + (elbow_rotation(side, eb) @ np.array([0, 0, -lf]))
    R_ref_upper = pose.segment(f"{prefix}_upper_arm")[0]
    R_new = rotation_between((R_ref_upper @ d_local[..., None])[..., 0], d_new) @ R_ref_upper
    R_ref_torso = pose.segment("torso")[0]
    angles = bm.shoulder_angles(np.swapaxes(R_ref_torso, -1, -2) @ R_new, side)
    out = q.copy()
    out[:, j:j + 3], out[:, j + 3] = angles, eb
    ok &= np.all(np.isfinite(out), axis=1) & body.free_limits.inside(out)
    return np.where(ok[:, None], out, q)


def wrist_ranges(body: bm.BodyModel, q: np.ndarray, side: str, c_ref: np.ndarray,
                 pose: bm.Pose | None = None) -> np.ndarray:
    """``(N,)`` the distance (m) of arm ``side``'s wrist of states ``q (N, 14)`` from the camera
    centre ``c_ref (3,)`` (reference frame); ``pose``: ``q``'s forward kinematics, if known."""
    prefix, _ = SIDES[side]
    if pose is None:
        pose = body.forward(np.atleast_2d(np.asarray(q, float)))
    W = pose.joint(f"{prefix}_wrist")
    return np.linalg.norm(W - np.asarray(c_ref, float), axis=1)


def reachable_range_change(body: bm.BodyModel, q: np.ndarray, side: str, delta: np.ndarray,
                           c_ref: np.ndarray, margin: float = 1e-3,
                           pose: bm.Pose | None = None) -> np.ndarray:
    """``delta (N,)`` (m, range changes of arm ``side``'s wrist along its camera ray from the
    camera centre ``c_ref``) clipped to the arm's reach: the wrist ``W + t u`` stays within
    ``(1 - margin)`` times the upper arm plus forearm of the shoulder ``S`` (the roots of
    ``|W - S + t u|^2 = R^2``; a wrist beyond it is brought to the nearest reachable point);
    0 where the ray misses that sphere. ``pose``: ``q``'s forward kinematics, if known."""
    prefix, _ = SIDES[side]
    if pose is None:
        pose = body.forward(np.atleast_2d(np.asarray(q, float)))
    S, W = pose.joint(f"{prefix}_shoulder"), pose.joint(f"{prefix}_wrist")
    u = W - np.asarray(c_ref, float)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    R = (1.0 - margin) * (body.skeleton.upper_arm + body.skeleton.forearm)
    b = np.sum(u * (W - S), axis=1)
    disc = b * b - (np.sum((W - S) ** 2, axis=1) - R * R)
    s = np.sqrt(np.maximum(disc, 0.0))
    return np.where(disc > 0.0, np.clip(np.asarray(delta, float), -b - s, -b + s), 0.0)


def keep_wrist_range(body: bm.BodyModel, q: np.ndarray, q_ref: np.ndarray, side: str,
                     T_cam_ref: np.ndarray, clip: bool = False) -> np.ndarray:
    """States ``(N, 14)``: arm ``side`` of ``q (N, 14)`` re-solved (:func:`wrist_depth_move`)
    so its wrist lies at the camera distance of ``q_ref``'s ``(N, 14)``, on its own camera
    ray (the wrist's image kept): a move across the ray at a given depth. Rows the move cannot
    reach (out of the arm's reach or the joint limits) are left unchanged; ``clip``: out of
    reach, moved to the reachable distance nearest to it
    (:func:`reachable_range_change`, the outer reach only) instead. (The numpy reference of
    :func:`kept_ranges`' compiled loop.)"""
    T_ref_cam = np.linalg.inv(np.asarray(T_cam_ref, float))
    c = T_ref_cam[:3, 3]
    pose = body.forward(np.atleast_2d(np.asarray(q, float)))
    delta = wrist_ranges(body, q_ref, side, c) - wrist_ranges(body, q, side, c, pose)
    if clip:
        delta = reachable_range_change(body, q, side, delta, c, pose=pose)
    return wrist_depth_move(body, q, side, delta, T_cam_ref, pose, T_ref_cam)


def kept_ranges(body: bm.BodyModel, q: np.ndarray, q_ref: np.ndarray, rows: np.ndarray,
                share: float, T_cam_ref: np.ndarray, clip: bool, rng: np.random.Generator,
                gates: dict[str, np.ndarray] | None = None,
                straight: float | None = None) -> np.ndarray:
    """A copy of states ``q (N, 14)`` where, per arm, each of ``rows`` (bool ``(N,)``) is
    drawn with probability ``share`` (times ``gates[side]``, ``(N,)`` or ``(1,)``, if given:
    :mod:`~humimic.perception.trackers.kpf.depth_gate`) and its wrist put back at ``q_ref``'s
    camera distance (:func:`keep_wrist_range`, compiled:
    :func:`~humimic.perception.trackers.kpf.depth_kernel.keep_range_rows`; one forward
    kinematics of ``q`` and of ``q_ref`` serves both arms, whose joints depend on the torso and
    their own DOFs only); ``straight`` (rad, optional): rows whose arm is nearly straight
    (:func:`nearly_straight`) are left alone, drawn or not."""
    q = np.array(q, float)
    picks = {}
    for side in SIDES:
        p = share if gates is None else share * gates[side]
        drawn = rows & (rng.random(len(q)) < p)
        if straight is not None:
            drawn &= ~nearly_straight(q, side, straight)
        picks[side] = np.flatnonzero(drawn)
    if not any(len(pick) for pick in picks.values()):
        return q
    pose, pose_ref = body.forward(q), body.forward(np.asarray(q_ref, float))
    c = np.linalg.inv(np.asarray(T_cam_ref, float))[:3, 3]
    out = q.copy()
    for side, pick in picks.items():
        if len(pick):
            kept_range_rows(body, q, pose, pose_ref, pick, side, c, clip, out)
    return out


def nearly_straight(q: np.ndarray, side: str, straight: float) -> np.ndarray:
    """``(N,)`` whether arm ``side``'s elbow flexion in states ``q (N, 14)`` is below
    ``straight`` (rad). Near the straight limit the kept range (:func:`keep_wrist_range`) is
    one-sided: the arm is at (nearly) full reach, so a wrist moved along its ray can come
    nearer the shoulder (the elbow bends) but not farther (out of reach, clipped to where it
    is): applied there, it only ever bends the arm."""
    return np.asarray(q, float)[:, SIDES[side][1] + 3] < straight
