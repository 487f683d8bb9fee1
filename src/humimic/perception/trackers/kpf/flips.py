"""Kinematic flips: the arm poses one camera cannot tell apart (Sminchisescu & Triggs 2003,
"Kinematic jump processes for monocular 3D human tracking").

With the shoulder fixed and the bone lengths known, the elbow's image pins it to a camera ray,
which meets the sphere of radius ``upper_arm`` about the shoulder twice: the elbow may be the
near or the far intersection. The same holds for the wrist on its ray and the sphere of radius
``forearm`` about the elbow. So an arm seen in the image has up to four 3-D poses with the same
joint images (and nearly the same limb silhouettes: only perspective widths and the limbs'
cross-sections differ): :func:`arm_flips` returns them, :func:`arm_from_joints` re-solves the
joint angles for given elbow and wrist positions.
"""

from __future__ import annotations

import numpy as np

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.depth import SIDES

#: The flips of :func:`arm_flips`: the wrist's, the elbow's (the wrist kept on its ray, at the
#: intersection nearer the old one), both.
FLIPS = ("wrist", "elbow", "both")


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def arm_from_joints(body: bm.BodyModel, q: np.ndarray, side: str, elbow: np.ndarray,
                    wrist: np.ndarray) -> np.ndarray:
    """States ``(N, 14)``: ``q`` with arm ``side`` re-solved so its elbow and wrist lie at
    ``elbow``, ``wrist`` ``(N, 3)`` (reference frame; at the skeleton's bone lengths from the
    shoulder and each other). The upper arm's frame: ``-z`` along shoulder -> elbow, ``+x``
    towards the forearm (the forearm in it is ``(sin EB, 0, -cos EB)``, kinematics' elbow
    rotation ``Rot(-y, EB)``); a straight arm keeps ``q``'s swivel."""
    prefix, j = SIDES[side]
    pose = body.forward(q)
    z = _unit(pose.joint(f"{prefix}_shoulder") - elbow)
    f = _unit(wrist - elbow)
    eb = np.arccos(np.clip(-np.sum(f * z, axis=1), -1.0, 1.0))
    x = f - np.sum(f * z, axis=1, keepdims=True) * z
    x_old = pose.segment(f"{prefix}_upper_arm")[0][:, :, 0]
    x_old = x_old - np.sum(x_old * z, axis=1, keepdims=True) * z
    straight = np.linalg.norm(x, axis=1, keepdims=True) < 1e-9
    x = _unit(np.where(straight, x_old, x))
    R_ref_upper = np.stack([x, np.cross(z, x), z], axis=2)
    R_ref_torso = pose.segment("torso")[0]
    out = np.array(q, float, copy=True)
    out[:, j:j + 3] = bm.shoulder_angles(np.swapaxes(R_ref_torso, -1, -2) @ R_ref_upper, side)
    out[:, j + 3] = eb
    return out


def _ray_sphere(c: np.ndarray, u: np.ndarray, centre: np.ndarray, r: float):
    """Ranges ``t`` of the two points ``c + t u`` (unit ``u``) at distance ``r`` from
    ``centre``: ``(near, far, real)``, NaN where the ray misses the sphere."""
    b = np.sum(u * (centre - c), axis=1)
    disc = b * b - (np.sum((centre - c) ** 2, axis=1) - r * r)
    real = disc >= 0.0
    s = np.sqrt(np.where(real, disc, np.nan))
    return b - s, b + s, real


def arm_flips(body: bm.BodyModel, q: np.ndarray, side: str, c_ref: np.ndarray
              ) -> dict[str, np.ndarray]:
    """The kinematic flips of arm ``side`` of states ``q (N, 14)`` seen from a camera centred
    at ``c_ref`` ``(3,)`` or ``(N, 3)`` (reference frame): ``{flip: (N, 14)}`` for
    :data:`FLIPS`, each with the same elbow and wrist images (rows NaN where the flipped
    elbow's sphere misses the wrist's ray). Joint limits are not checked."""
    prefix, _ = SIDES[side]
    q = np.atleast_2d(np.asarray(q, float))
    pose = body.forward(q)
    S, E, W = (pose.joint(f"{prefix}_{n}") for n in ("shoulder", "elbow", "wrist"))
    lf = body.skeleton.forearm
    c = np.broadcast_to(np.asarray(c_ref, float), E.shape)
    ue, uw = _unit(E - c), _unit(W - c)
    te, tw = np.linalg.norm(E - c, axis=1), np.linalg.norm(W - c, axis=1)
    # the other root: the two ranges sum to 2 u.(centre - c)
    W_flip = c + (2.0 * np.sum(uw * (E - c), axis=1) - tw)[:, None] * uw
    E_flip = c + (2.0 * np.sum(ue * (S - c), axis=1) - te)[:, None] * ue
    near, far, real = _ray_sphere(c, uw, E_flip, lf)
    keep = np.where(np.abs(near - tw) <= np.abs(far - tw), near, far)
    other = np.where(np.abs(near - tw) <= np.abs(far - tw), far, near)
    out = {"wrist": arm_from_joints(body, q, side, E, W_flip)}
    for name, t in (("elbow", keep), ("both", other)):
        sol = arm_from_joints(body, q, side, E_flip, c + np.where(real, t, tw)[:, None] * uw)
        out[name] = np.where(real[:, None], sol, np.nan)
    return out


def flip_free_error(body: bm.BodyModel, q_est: np.ndarray, q_true: np.ndarray, side: str,
                    c_ref: np.ndarray, joint: str = "wrist") -> np.ndarray:
    """``(N,)`` the distance (m) from the true ``joint`` of arm ``side`` to the nearest of the
    estimate's and its kinematic flips' (the error left once the monocular depth flips are
    forgiven: what the image cues localise); ``c_ref`` ``(3,)`` or ``(N, 3)`` the camera
    centres (reference frame)."""
    prefix, _ = SIDES[side]
    name = f"{prefix}_{joint}"
    q_est = np.atleast_2d(np.asarray(q_est, float))
    truth = body.forward(q_true).joint(name)
    d = [np.linalg.norm(body.forward(q_est).joint(name) - truth, axis=1)]
    for f in arm_flips(body, q_est, side, c_ref).values():
        ok = np.all(np.isfinite(f), axis=1)
        d.append(np.where(ok, np.linalg.norm(
            body.forward(np.where(ok[:, None], f, q_est)).joint(name) - truth, axis=1), np.inf))
    return np.min(np.stack(d), axis=0)


def flip_jumps(body: bm.BodyModel, pred: np.ndarray, T_cam_ref: np.ndarray, share: float,
               limits: bm.JointLimits, rng: np.random.Generator) -> np.ndarray:
    """Kinematic jumps (``KpfConfig.flip_share``): a ``share`` of the states ``pred (N, 14)``
    per arm replaced in place by one of their flips (drawn uniformly; kept where it exists and
    lies within ``limits``); ``T_cam_ref`` the camera's pose (reference -> camera)."""
    c_ref = np.linalg.inv(np.asarray(T_cam_ref, float))[:3, 3]
    for side in SIDES:
        pick = np.flatnonzero(rng.random(len(pred)) < share)
        if len(pick) == 0:
            continue
        kind = rng.integers(0, len(FLIPS), len(pick))
        flips = arm_flips(body, pred[pick], side, c_ref)
        new = np.stack([flips[f] for f in FLIPS])[kind, np.arange(len(pick))]
        ok = np.all(np.isfinite(new), axis=1)
        ok[ok] = limits.inside(new[ok])
        pred[pick[ok]] = new[ok]
    return pred
