"""TBP's measurement functions and priors (Menezes secs. 6.2-6.3), vectorised over particles.

For eight arm angles ``q (N, 8)`` and the frame's torso pose, the body model
(:mod:`humimic.bodymodel`) is posed and projected with hidden-part removal; then

* shape and motion (eq. 5): ``D = mean_j min(I_DT(j), K I'_DT(j))`` over the *visible*
  contour points of the six arm parts, ``I'`` the distance transform of the moving edges
  (optical flow); ``-lambda_s D^2 / (2 sigma_s^2)`` (eq. 2);
* colour patches (eq. 6): six patches (upper arm, forearm, hand of each arm; a square on the
  limb's image quadrilateral / the hand's ellipse) against reference histograms taken on the
  first frame, each weighted by ``lambda_p``;
* skin (the first stage's cue, "virtual patches related to the two hands projection and
  skin-like image ROIs"): ``D_k = 1 - mean skin posterior`` inside the hands' outlines;
* priors (eq. 19): the stabiliser ``-lambda_st |q - q_def|^2`` (sec. 6.2.1) and the
  collision term ``-lambda_co f_co`` (eq. 18: an elbow or wrist inside the torso's elliptic
  cylinder).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.bodymodel.features import contour_points
from humimic.bodymodel.model import BodyModel, Cone, Pose
from humimic.bodymodel.projection import project
from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.edges import DT_CAP_PX, sample, shape_log_likelihood
from humimic.perception.cues.histograms import (
    QuantizedImage,
    color_log_likelihood,
    patch_histograms,
)
from humimic.perception.cues.motion import MotionEdgeMaps, sample_pair
from humimic.perception.trackers.frame_cues import FrameCues, frame_cues
from humimic.sensors.camera_model import CameraImage

ARM_PARTS = ("r_upper_arm", "r_forearm", "r_hand", "l_upper_arm", "l_forearm", "l_hand")
HANDS = ("r_hand", "l_hand")
INSCRIBED = np.array([[0.0, 0.0, 1.0, 1.0]])
OFF_IMAGE = -1.0e6


ArmView = FrameCues


def arm_view(frame: CameraImage, flow: np.ndarray | None, lut: ColorLUT, bins: int,
             colour_edges: bool = False, colours: str = "rgb") -> ArmView:
    return frame_cues(frame, bins, lut, flow, colour_edges, colours)


@dataclass(frozen=True)
class ArmProjection:
    pose: Pose
    uv: np.ndarray
    """(N, 6, n, 2) contour points of :data:`ARM_PARTS` (px; off-image sentinel if invalid)."""
    visible: np.ndarray
    """(N, 6, n) bool, after hidden-part removal."""
    hand_inner: np.ndarray
    """(N, 2, V, 2) the hands' outlines shrunk towards their centroids (px)."""
    patches: np.ndarray
    """(N, 6, 3) ``(u, v, side)`` of the colour patches (px)."""


def project_arms(body: BodyModel, q: np.ndarray, torso: np.ndarray, view: ArmView,
                 n_points: int, shrink: float = 0.6) -> ArmProjection:
    """Pose and project the arms of every particle (``body`` frees the 8 arm DOFs)."""
    pose = body.forward(q, fixed=torso)
    bv = project(body, pose, view.intrinsics, view.T_cam_base, n_vertices=12)
    pts = contour_points(bv, n_points)
    idx = [bv.index(p) for p in ARM_PARTS]
    ok = bv.valid[:, idx]
    uv = np.where(ok[..., None, None], pts.uv[:, idx], OFF_IMAGE)
    uv = np.where(np.isfinite(uv), uv, OFF_IMAGE)
    out = bv.outline.uv
    patches = np.empty((len(q), len(ARM_PARTS), 3))
    inner = []
    for k, name in enumerate(ARM_PARTS):
        i = bv.index(name)
        if isinstance(body.part(name).shape, Cone):
            c = int(np.flatnonzero(bv.cone_idx == i)[0])
            sides = bv.sides_uv[:, c]                                    # (N, 2, 2, 2)
            centre = sides.mean(axis=(1, 2))
            width = np.linalg.norm(sides[:, 0] - sides[:, 1], axis=-1).mean(axis=1)
        else:
            poly = out[:, i]
            centre = poly.mean(axis=1)
            width = np.linalg.norm(poly - centre[:, None], axis=-1).min(axis=1) * 2.0
            if name in HANDS:
                inner.append(centre[:, None] + shrink * (poly - centre[:, None]))
        patches[:, k] = np.column_stack([centre, 0.7 * width])
    patches = np.where(np.isfinite(patches) & ok[..., None], patches, [OFF_IMAGE, OFF_IMAGE, 1.0])
    hand_inner = np.stack(inner, 1)
    hand_inner = np.where(np.isfinite(hand_inner), hand_inner, OFF_IMAGE)
    return ArmProjection(pose, uv, pts.visible[:, idx] & ok[..., None], hand_inner, patches)


def hand_interiors(hands: BodyModel, q: np.ndarray, torso: np.ndarray, view: ArmView,
                   shrink: float = 0.6) -> np.ndarray:
    """``(N, 2, V, 2)`` the hands' outlines shrunk towards their centroids (px), from a model
    ``hands`` holding only the two hand parts (the first stage's cheap projection)."""
    bv = project(hands, hands.forward(q, fixed=torso), view.intrinsics, view.T_cam_base,
                 n_vertices=8)
    poly = bv.outline.uv[:, [bv.index(h) for h in HANDS]]
    c = poly.mean(axis=2, keepdims=True)
    out = c + shrink * (poly - c)
    return np.where(np.isfinite(out), out, OFF_IMAGE)


def shape_motion_distance(proj: ArmProjection, maps: MotionEdgeMaps, K: float,
                          cap_px: float = DT_CAP_PX) -> np.ndarray:
    """Menezes eq. 5 over the visible arm contour points: ``(N,)`` px (``cap_px`` when none is
    visible). Each point's distance is capped at ``cap_px``: a contour with no edge near it
    (an arm in front of a shirt of its own colour) then costs a constant instead of swamping
    the points that do see an edge."""
    both = np.stack([maps.dt, maps.dt_moving], axis=-1)
    v = sample_pair(both, proj.uv, DT_CAP_PX)                          # (N, 6, n, 2)
    d = np.minimum(np.minimum(v[..., 0], K * v[..., 1]), cap_px)       # Menezes eq. 5
    w = proj.visible.astype(float)
    n = w.sum(axis=(1, 2))
    return np.where(n > 0, (d * w).sum(axis=(1, 2)) / np.maximum(n, 1), cap_px)


def skin_distance(hand_inner: np.ndarray, skin: np.ndarray) -> np.ndarray:
    """``1 - mean skin posterior`` at the points ``(N, 2, V, 2)`` inside the two hands'
    outlines, ``(N,)`` in [0, 1]."""
    return 1.0 - sample(skin, hand_inner, 0.0).mean(axis=(1, 2))


def patch_histograms_all(proj: ArmProjection, qimage: QuantizedImage) -> np.ndarray:
    """``(N, 6, 3, bins)`` histograms of the six colour patches."""
    return np.stack([patch_histograms(qimage, proj.patches[:, k], INSCRIBED, grid=6)[:, 0]
                     for k in range(len(ARM_PARTS))], 1)


def collision(pose: Pose, body: BodyModel, margin: float = 0.0) -> np.ndarray:
    """Eq. 18's ``f_co`` ``(N,)``: 1 where an elbow or wrist lies inside the torso's elliptic
    cylinder (the torso part's extent in the torso frame), else 0."""
    torso = body.part("torso").shape
    R_t, p_t = pose.segment("torso")
    hit = np.zeros(len(pose.q), bool)
    for j in ("r_elbow", "r_wrist", "l_elbow", "l_wrist"):
        local = ((pose.joint(j) - p_t)[:, None, :] @ R_t)[:, 0]        # torso frame
        if isinstance(torso, Cone):
            a, b, z0, z1 = torso.a, torso.b, 0.0, torso.length
            local = local - body.part("torso").p_seg_part
        else:
            a, b = torso.semi_axes[0], torso.semi_axes[1]
            z0, z1 = -torso.semi_axes[2], torso.semi_axes[2]
            local = local - body.part("torso").p_seg_part
        r = (local[:, 0] / (a + margin)) ** 2 + (local[:, 1] / (b + margin)) ** 2
        hit |= (r < 1.0) & (local[:, 2] > z0) & (local[:, 2] < z1)
    return hit.astype(float)


def stabiliser(q: np.ndarray, q_def: np.ndarray) -> np.ndarray:
    """``|q - q_def|^2`` (rad^2) of sec. 6.2.1's prior ``exp(-lambda_st |x_def - x|^2)``."""
    return np.sum((q - q_def) ** 2, axis=1)


def log_likelihood_terms(proj: ArmProjection, view: ArmView, q: np.ndarray, body: BodyModel,
                         w: dict, refs: np.ndarray | None) -> dict[str, np.ndarray]:
    """Eq. 19's terms ``(N,)`` each, by cue: ``shape`` (shape + motion, eq. 5), ``skin``, one
    ``colour_<part>`` per patch of :data:`ARM_PARTS` (eq. 6; none without references),
    ``stabiliser`` (sec. 6.2.1) and ``collision`` (eq. 18); their sum is
    :func:`full_log_likelihood`."""
    D = shape_motion_distance(proj, view.maps, w["K"], w["cap_px"])
    out = {"shape": shape_log_likelihood(D, w["sigma_s"], w["lambda_s"]),     # eq. 2, eq. 5
           "skin": shape_log_likelihood(skin_distance(proj.hand_inner, view.skin),
                                        w["sigma_k"])}
    if refs is not None:
        hists = patch_histograms_all(proj, view.qimage)
        for k, part in enumerate(ARM_PARTS):
            lam = np.full((1, 3), w["lambda_c"][k])
            out[f"colour_{part}"] = color_log_likelihood(hists[:, k:k + 1], refs[k:k + 1],
                                                         w["sigma_c"], lam)      # eq. 6
    out["stabiliser"] = -w["lambda_st"] * stabiliser(q, w["q_def"])              # sec. 6.2.1
    out["collision"] = -w["lambda_co"] * collision(proj.pose, body)              # eq. 18
    return out


def full_log_likelihood(proj: ArmProjection, view: ArmView, q: np.ndarray, body: BodyModel,
                        w: dict, refs: np.ndarray | None) -> np.ndarray:
    """Eq. 19: shape + motion, colour patches, skin, stabiliser and collision, with the
    weights ``w`` (``lambda_s, sigma_s, K, sigma_c, lambda_c (6,), sigma_k, lambda_st,
    lambda_co, q_def``)."""
    return sum(log_likelihood_terms(proj, view, q, body, w, refs).values())
