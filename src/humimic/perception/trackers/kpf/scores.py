"""Scores of a ``kpf`` tracker against the avatar's ground truth (``trackers.<name>.*``).

Per frame the true joints are the body model's forward kinematics of the avatar's true state
(the model's skeleton is the avatar's, so they are the avatar's joints). The wrist error is
Schmidt's: the distance between the true wrist and the end of the model's forearm, averaged
over frames (Table 1); it is split along the camera ray through the true wrist into its
depth (along the ray) and image-plane (``lateral``, across the ray) components (the camera's
z axis would count an off-axis wrist's depth error as lateral: at the wide eye's image edge, a
third of it). ``wrist_flip_free_mm``: the error to the nearest of the estimate and its
kinematic flips (:mod:`~humimic.perception.trackers.kpf.flips`, the arm poses with the same
joint images), the part of the error the monocular depth ambiguity does not explain.
The wrist and elbow scores are the RIGHT arm's (Table 1's pointing arm); ``left_wrist_error_mm``,
``left_elbow_error_mm`` and ``left_arm_rmse_deg`` the other arm's (a straight hanging arm the
tracker bends shows there, not in the right arm's scores).
``lost_fraction``: frames with the wrist more than :data:`LOST_M` off. ``truth_margin_nats`` /
``estimate_above_truth_fraction`` (:func:`truth_margin_scores`): how the tracker's own
likelihood ranks the true pose against its estimate, telling a biased likelihood (the
estimate scored above the truth) from a search that does not reach the truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.flips import flip_free_error

ENDPOINTS = ("r_shoulder", "r_elbow", "r_wrist", "l_shoulder", "l_elbow", "l_wrist")
#: A frame whose wrist error exceeds this counts as lost (issue 14).
LOST_M = 0.2
ARM = slice(6, 14)


@dataclass
class KpfRecord:
    t: list = field(default_factory=list)
    q: list = field(default_factory=list)
    ends: list = field(default_factory=list)
    lost: list = field(default_factory=list)
    compute_s: list = field(default_factory=list)
    cpu_s: list = field(default_factory=list)
    iterations: list = field(default_factory=list)
    T_cam_base: list = field(default_factory=list)
    truth_margin: list = field(default_factory=list)
    """Per frame ``log p(y | true pose) - log p(y | estimate)`` (nats), the tracker's own
    likelihood (eqs. 9-10, its colour references after the frame's adaptation)."""

    def add(self, t, q, ends, lost, compute_s, cpu_s, iterations, T_cam_base,
            truth_margin: float = float("nan")) -> None:
        self.t.append(t)
        self.q.append(np.asarray(q, float))
        self.ends.append(np.stack([ends[j] for j in ENDPOINTS]))
        self.lost.append(bool(lost))
        self.compute_s.append(compute_s)
        self.cpu_s.append(cpu_s)
        self.iterations.append(iterations)
        self.T_cam_base.append(T_cam_base)
        self.truth_margin.append(float(truth_margin))


def truth(world, body: bm.BodyModel, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """True states ``(T, 14)`` and joints ``(T, len(ENDPOINTS), 3)`` (base frame) at times
    ``t``."""
    q = np.atleast_2d(bm.truth_state(world, world.gt.index_of(np.asarray(t)), "base"))
    pose = body.forward(q)
    return q, np.stack([pose.joint(j) for j in ENDPOINTS], axis=1)


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def errors(rec: KpfRecord, world, body: bm.BodyModel) -> dict[str, np.ndarray]:
    """Per-frame errors: ``wrist``, ``elbow``, ``left_wrist``, ``left_elbow`` (m), ``lateral``
    and ``depth`` wrist components (m, across and along the camera ray through the true
    wrist), ``flip_free`` (m, the wrist's to the nearest of the estimate's kinematic flips),
    ``angles`` (T, 8) arm-angle errors (rad)."""
    q_true, j_true = truth(world, body, np.asarray(rec.t))
    ends = np.stack(rec.ends)
    wi, ei = ENDPOINTS.index("r_wrist"), ENDPOINTS.index("r_elbow")
    lw, le = ENDPOINTS.index("l_wrist"), ENDPOINTS.index("l_elbow")
    d = ends[:, wi] - j_true[:, wi]                                       # base frame
    depth, lateral = ray_split(d, j_true[:, wi], np.stack(rec.T_cam_base))
    c_base = camera_centres(np.stack(rec.T_cam_base))
    return {"wrist": np.linalg.norm(d, axis=1),
            "elbow": np.linalg.norm(ends[:, ei] - j_true[:, ei], axis=1),
            "left_wrist": np.linalg.norm(ends[:, lw] - j_true[:, lw], axis=1),
            "left_elbow": np.linalg.norm(ends[:, le] - j_true[:, le], axis=1),
            "lateral": lateral, "depth": depth,
            "flip_free": flip_free_error(body, np.stack(rec.q), q_true, "R", c_base),
            "angles": wrap(np.stack(rec.q)[:, ARM] - q_true[:, ARM])}


def camera_centres(T_cam_ref: np.ndarray) -> np.ndarray:
    """``(T, 3)`` camera centres in the reference frame of ``T_cam_ref (T, 4, 4)``."""
    R, t = T_cam_ref[:, :3, :3], T_cam_ref[:, :3, 3]
    return -np.einsum("tji,tj->ti", R, t)


def ray_split(d: np.ndarray, p_true: np.ndarray, T_cam_ref: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """Errors ``d (T, 3)`` at true points ``p_true (T, 3)`` (reference frame) split along the
    camera ray through ``p_true``: ``|d . u|`` (depth) and ``|d - (d . u) u|`` (image plane),
    ``u`` the ray's unit direction."""
    u = p_true - camera_centres(T_cam_ref)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    along = np.sum(d * u, axis=1)
    return np.abs(along), np.linalg.norm(d - along[:, None] * u, axis=1)


def kpf_metrics(rec: KpfRecord, world, body: bm.BodyModel, camera: str) -> dict:
    if not rec.t:
        return {"frames": 0, "frames_per_s": 0.0, "lost_fraction": 1.0}
    e = errors(rec, world, body)
    mm = 1e3
    return {
        "frames": len(rec.t),
        "frames_per_s": float(len(rec.t) / max(sum(rec.compute_s), 1e-9)),
        "frames_per_cpu_s": float(len(rec.t) / max(sum(rec.cpu_s), 1e-9)),
        "lost_fraction": float(np.mean(e["wrist"] > LOST_M)),
        "reported_lost_fraction": float(np.mean(rec.lost)),
        "wrist_error_mm": mm * float(e["wrist"].mean()),
        "wrist_lateral_mm": mm * float(e["lateral"].mean()),
        "wrist_depth_mm": mm * float(e["depth"].mean()),
        "wrist_flip_free_mm": mm * float(e["flip_free"].mean()),
        "elbow_error_mm": mm * float(e["elbow"].mean()),
        "joint_rmse_deg": float(np.degrees(np.sqrt(np.mean(e["angles"] ** 2)))),
        "right_arm_rmse_deg": float(np.degrees(np.sqrt(np.mean(e["angles"][:, :4] ** 2)))),
        "left_wrist_error_mm": mm * float(e["left_wrist"].mean()),
        "left_elbow_error_mm": mm * float(e["left_elbow"].mean()),
        "left_arm_rmse_deg": float(np.degrees(np.sqrt(np.mean(e["angles"][:, 4:] ** 2)))),
        "iterations_mean": float(np.mean(rec.iterations)),
        **truth_margin_scores(np.asarray(rec.truth_margin, float)),
    }


def truth_margin_scores(margin: np.ndarray) -> dict:
    """Scores of the per-frame ``log p(y | truth) - log p(y | estimate)`` (:class:`KpfRecord`):
    ``truth_margin_nats`` its mean, ``estimate_above_truth_fraction`` the share of frames where
    the likelihood scores the estimate above the true pose (a bias of the likelihood there;
    a positive margin with a wrong estimate is a failure of the search). NaN frames (no
    margin recorded) are left out; None without any."""
    m = margin[np.isfinite(margin)]
    if len(m) == 0:
        return {"truth_margin_nats": None, "estimate_above_truth_fraction": None}
    return {"truth_margin_nats": float(m.mean()),
            "estimate_above_truth_fraction": float(np.mean(m < 0.0))}
