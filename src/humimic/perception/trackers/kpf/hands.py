"""A skin-blob proposal for the arms (our extension of Schmidt et al.'s kernel particle filter,
importance sampling from a detector as Isard & Blake's ICONDENSATION).

The tracker's likelihood prefers the true pose over its estimate in almost every frame (the
Table-1 side runs: by 3 nats while the arm rises), but a random walk of extent D rarely
lands a fast-moving arm near it, and the motion model's velocity (from the last two
estimates) lags while the arm accelerates. The hand, though, is a skin blob the skin cue
already segments. :func:`hand_blob_moves` turns a share of the particles' arms rigidly
about the shoulder (elbow flexion kept) towards the skin blob nearest to each hand (within
``radius_px``; a point of the blob: its centroid jittered by half the blob's size), aiming
the hand's centre at the point of the blob's ray nearest to it: the hand moves across the
ray, towards the blob in the image, its depth kept to first order (moves that kept the
hand's range and re-solved the elbow, or put the hand exactly on the ray at the sphere
crossing nearer the old hand, added depth changes the likelihood cannot judge: measured
worse). The reweighting keeps the dynamics' KDE as the prior (the moved particles are a
proposal, as the depth moves). Measured on the Table-1 frames (``docs/schmidt_kpf_notes.md``,
``i14-side2``): no image lag on the fast rise any more, but the depth left free drifts more;
off in Table 1.
"""

from __future__ import annotations

import numpy as np

from humimic import bodymodel as bm
from humimic.maths.rotations import rotation_between
from humimic.perception.trackers.kpf.depth import SIDES


def part_centres(body: bm.BodyModel, pose: bm.Pose, part: str) -> np.ndarray:
    """``(N, 3)`` the centre of ``part`` (reference frame) in each posed skeleton."""
    lay = body.layout
    i = body.part_names.index(part)
    R, p = pose.R[:, lay.segment[i]], pose.p[:, lay.segment[i]]
    return p + R @ lay.p_seg_part[i]


def ray_points(intr, T_cam_ref: np.ndarray, uv: np.ndarray, ranges: np.ndarray) -> np.ndarray:
    """``(N, 3)`` reference-frame points seen at pixels ``uv (N, 2)`` at distances ``ranges
    (N,)`` (m) from the camera centre (``T_cam_ref``: reference-frame points -> camera)."""
    xy = intr.undistort_normalized(np.asarray(uv, float))
    d = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    T = np.asarray(T_cam_ref, float)
    R_ref_cam, c = T[:3, :3].T, -T[:3, :3].T @ T[:3, 3]
    return c + (d @ R_ref_cam.T) * np.asarray(ranges, float)[:, None]


def nearest_blob(uv: np.ndarray, centres: np.ndarray, radius: float) -> np.ndarray:
    """``(N,)`` index of the blob centre (``centres (B, 2)``) nearest to each point ``uv (N,
    2)``, -1 where none lies within ``radius`` (or the point is NaN)."""
    if len(centres) == 0 or len(uv) == 0:
        return np.full(len(uv), -1)
    d2 = np.sum((uv[:, None, :] - centres[None, :, :]) ** 2, axis=-1)
    with np.errstate(invalid="ignore"):
        d2 = np.where(np.isfinite(d2), d2, np.inf)
    k = np.argmin(d2, axis=1)
    return np.where(d2[np.arange(len(uv)), k] <= radius * radius, k, -1)


def closest_on_rays(c: np.ndarray, ray: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``(N, 3)`` the points of the rays ``c + t ray`` (``c (3,)``, unit ``ray (N, 3)``)
    nearest to the points ``X (N, 3)`` (the feet of the perpendiculars)."""
    return c + np.sum((X - c) * ray, axis=1)[:, None] * ray


def arm_turn_to(body: bm.BodyModel, q: np.ndarray, side: str, H: np.ndarray, H_new: np.ndarray,
                pose: bm.Pose) -> np.ndarray:
    """States ``(N, 14)``: arm ``side`` of ``q`` turned rigidly about the shoulder (elbow kept)
    by the smallest rotation taking its point ``H (N, 3)`` (e.g. the hand's centre) to the
    direction of ``H_new (N, 3)``; unchanged where ``H_new`` is NaN or the new shoulder
    angles leave the joint limits."""
    prefix, j = SIDES[side]
    S = pose.joint(f"{prefix}_shoulder")
    ok = np.all(np.isfinite(H_new), axis=1)
    R = rotation_between(H - S, np.where(ok[:, None], H_new, H) - S)
    R_ref_upper = pose.segment(f"{prefix}_upper_arm")[0]
    R_ref_torso = pose.segment("torso")[0]
    angles = bm.shoulder_angles(np.swapaxes(R_ref_torso, -1, -2) @ R @ R_ref_upper, side)
    out = q.copy()
    out[:, j:j + 3] = angles
    ok &= np.all(np.isfinite(out), axis=1) & body.free_limits.inside(out)
    return np.where(ok[:, None], out, q)


def hand_blob_moves(body: bm.BodyModel, q: np.ndarray, side: str, centres: np.ndarray,
                    areas: np.ndarray, intr, T_cam_ref: np.ndarray, radius_px: float,
                    rng: np.random.Generator) -> np.ndarray:
    """States ``(N, 14)``: arm ``side`` of each ``q (N, 14)`` turned about the shoulder (elbow
    kept) towards the point nearest to its hand's centre on the ray through the nearest
    skin blob (centres ``(B, 2)`` px, areas ``(B,)`` px^2) within ``radius_px`` (a point of
    the blob: its centre jittered by half its size): the hand moves across the ray, its
    depth kept to first order (the two arm positions with the hand exactly on the ray, where
    it exists, are each other's depth flip near the fronto-parallel plane: measured to make
    the tracker jump between them). Particles without a blob in reach, or whose new shoulder
    angles leave the joint limits, are left unchanged."""
    q = np.asarray(q, float)
    pose = body.forward(q)
    T = np.asarray(T_cam_ref, float)
    H = part_centres(body, pose, f"{SIDES[side][0]}_hand")
    H_cam = H @ T[:3, :3].T + T[:3, 3]
    k = nearest_blob(intr.project(H_cam), centres, radius_px)
    ok = k >= 0
    if not ok.any():
        return q
    half = 0.5 * np.sqrt(areas[k[ok]])[:, None]
    uv = centres[k[ok]] + rng.uniform(-1.0, 1.0, (int(ok.sum()), 2)) * half
    c = -T[:3, :3].T @ T[:3, 3]
    ray = ray_points(intr, T, uv, np.ones(len(uv))) - c
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    H_new = np.full_like(H, np.nan)
    H_new[ok] = closest_on_rays(c, ray, H[ok])
    return arm_turn_to(body, q, side, H, H_new, pose)
