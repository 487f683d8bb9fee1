"""Trajectory errors: absolute (APE/ATE) and relative (RPE) pose errors, translation part, with
evo's conventions (Grupp, github.com/MichaelGrupp/evo) so the numbers compare.

* Poses are ``(N, 4, 4)`` ``T_world_body`` with time stamps ``(N,)`` (s); TUM files hold
  ``timestamp tx ty tz qx qy qz qw`` per line (:func:`read_tum`).
* Association (:func:`associate`): starting from the trajectory with fewer poses, each of its
  stamps is paired with the nearest stamp of the other if they differ by at most ``max_diff``
  (0.01 s by default), as ``evo.core.sync.associate_trajectories``.
* APE (Sturm et al., IROS 2012, the TUM benchmark's ATE): after aligning the estimate
  (:mod:`humimic.maths.align`), ``e_i = ||p_ref_i - p_est_i||``.
* RPE: for index pairs ``(i, i + delta)`` taken every ``delta`` poses (evo's default, not all
  pairs), ``E_i = (Q_i^-1 Q_{i+d})^-1 (P_i^-1 P_{i+d})`` and ``e_i = ||trans(E_i)||``.
* The RMSE is over the errors ``e_i`` (:func:`humimic.maths.stats.rmse`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from humimic.maths.align import Align, alignment, apply_alignment
from humimic.maths.stats import rmse

#: Largest time difference (s) of associated poses (evo's default).
MAX_DIFF_S = 0.01


def read_tum(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(t (N,), T (N, 4, 4))`` from a TUM trajectory file (``#`` comments allowed)."""
    data = np.loadtxt(path, comments="#", ndmin=2)
    if data.shape[1] != 8:
        raise ValueError(f"{path}: expected 8 columns (timestamp tx ty tz qx qy qz qw), "
                         f"got {data.shape[1]}")
    return data[:, 0], poses_from(data[:, 1:4], data[:, 4:8])


def write_tum(path: str | Path, t: np.ndarray, T: np.ndarray) -> None:
    """Write poses ``(N, 4, 4)`` at times ``t`` as a TUM trajectory file."""
    q = Rotation.from_matrix(T[:, :3, :3]).as_quat()  # xyzw
    np.savetxt(path, np.column_stack([t, T[:, :3, 3], q]), fmt="%.9f",
               header="timestamp tx ty tz qx qy qz qw")


def poses_from(p: np.ndarray, q_xyzw: np.ndarray) -> np.ndarray:
    """``(N, 4, 4)`` poses from positions ``(N, 3)`` and quaternions ``(N, 4)`` (xyzw)."""
    T = np.zeros((len(p), 4, 4))
    T[:, :3, :3] = Rotation.from_quat(q_xyzw).as_matrix()
    T[:, :3, 3] = p
    T[:, 3, 3] = 1.0
    return T


def associate(t_a: np.ndarray, t_b: np.ndarray, max_diff: float = MAX_DIFF_S
              ) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(i_a, i_b)`` of associated stamps (see the module docstring); ``t_b`` sorted."""
    t_a, t_b = np.asarray(t_a, float), np.asarray(t_b, float)
    swap = len(t_a) > len(t_b)  # start from the one with fewer poses
    short, long_ = (t_b, t_a) if swap else (t_a, t_b)
    j = np.clip(np.searchsorted(long_, short, side="right"), 0, len(long_) - 1)
    up = long_[j] - short
    lo = np.where(j > 0, short - long_[np.maximum(j - 1, 0)], np.inf)
    best = np.where((up <= max_diff) & (up < lo), j, np.where(lo <= max_diff, j - 1, -1))
    keep = best >= 0
    i_short, i_long = np.flatnonzero(keep), best[keep]
    return (i_long, i_short) if swap else (i_short, i_long)


@dataclass(frozen=True)
class TrajectoryError:
    """Per-pair translation errors (m) and what produced them."""

    errors: np.ndarray
    pairs: int
    align: str
    scale: float
    """Scale of the alignment (1 unless ``sim3``)."""

    @property
    def rmse_m(self) -> float:
        return rmse(self.errors)


def _associated(t_ref, T_ref, t_est, T_est, max_diff):
    i, j = associate(t_ref, t_est, max_diff)
    if len(i) == 0:
        raise ValueError(f"no poses associated within {max_diff} s")
    return T_ref[i], T_est[j]


def ape(t_ref: np.ndarray, T_ref: np.ndarray, t_est: np.ndarray, T_est: np.ndarray,
        align: Align = "none", max_diff: float = MAX_DIFF_S) -> TrajectoryError:
    """Absolute pose error, translation part, after ``align``."""
    Q, P = _associated(t_ref, T_ref, t_est, T_est, max_diff)
    R, t, s = alignment(P[:, :3, 3], Q[:, :3, 3], align)
    P = apply_alignment(P, R, t, s)
    e = np.linalg.norm(Q[:, :3, 3] - P[:, :3, 3], axis=1)
    return TrajectoryError(e, len(e), align, s)


def relative_poses(T: np.ndarray, delta: int) -> np.ndarray:
    """``T_i^-1 T_{i+delta}`` for i = 0, delta, 2 delta, ... (consecutive pairs)."""
    ids = np.arange(0, len(T), delta)
    a, b = T[ids[:-1]], T[ids[1:]]
    Ra_T = np.swapaxes(a[:, :3, :3], 1, 2)
    out = np.zeros_like(a)
    out[:, :3, :3] = Ra_T @ b[:, :3, :3]
    out[:, :3, 3] = np.einsum("nij,nj->ni", Ra_T, b[:, :3, 3] - a[:, :3, 3])
    out[:, 3, 3] = 1.0
    return out


def rpe(t_ref: np.ndarray, T_ref: np.ndarray, t_est: np.ndarray, T_est: np.ndarray,
        delta: int = 1, align: Align = "none", max_diff: float = MAX_DIFF_S
        ) -> TrajectoryError:
    """Relative pose error over ``delta`` poses, translation part (after ``align``; only a
    ``sim3`` alignment changes it, through its scale)."""
    if delta < 1:
        raise ValueError(f"delta must be a whole number of poses >= 1, got {delta}")
    Q, P = _associated(t_ref, T_ref, t_est, T_est, max_diff)
    R, t, s = alignment(P[:, :3, 3], Q[:, :3, 3], align)
    P = apply_alignment(P, R, t, s)
    dQ, dP = relative_poses(Q, delta), relative_poses(P, delta)
    # E = dQ^-1 dP; its translation is R_dQ^T (t_dP - t_dQ)
    e = np.linalg.norm(np.einsum("nji,nj->ni", dQ[:, :3, :3], dP[:, :3, 3] - dQ[:, :3, 3]),
                       axis=1)
    return TrajectoryError(e, len(e), align, s)
