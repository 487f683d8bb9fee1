"""Rigid and similarity alignment of point sets (Umeyama 1991), for trajectory errors.

``umeyama(src, dst, with_scale)`` finds ``s, R, t`` minimising ``sum ||dst_i - (s R src_i + t)||^2``
(S. Umeyama, "Least-squares estimation of transformation parameters between two point
patterns", IEEE TPAMI 13(4), 1991, eqs. 34-43). :func:`alignment` names the three uses of
trajectory evaluation: ``none`` (the estimate is already in the reference frame, e.g. the
paper's W fixed by the screen's corners), ``se3`` (rotation + translation) and ``sim3``
(+ scale, for monocular estimates of arbitrary scale).

A Sim(3) alignment to a reference that does not move (a head standing still) is undetermined:
the least-squares scale is 0, which collapses the estimate onto the reference's point and
scores an ATE of exactly 0; :func:`umeyama` raises :class:`DegenerateAlignment` there. (evo
refuses any covariance of rank < 2, a straight line too; there the rotation about the line is
arbitrary but the translation errors, and the scale, are not, so they are kept.)
"""

from __future__ import annotations

from typing import Literal

import numpy as np

Align = Literal["none", "se3", "sim3"]
ALIGNMENTS: tuple[str, ...] = ("none", "se3", "sim3")


class DegenerateAlignment(ValueError):
    """The points do not determine the similarity alignment (their covariance is 0)."""


def umeyama(src: np.ndarray, dst: np.ndarray, with_scale: bool = False
            ) -> tuple[np.ndarray, np.ndarray, float]:
    """``(R (3, 3), t (3,), s)`` with ``dst ~ s R src + t`` in the least-squares sense
    (Umeyama eqs. 34-43); ``src``, ``dst`` are ``(N, 3)`` corresponding points, N >= 3.
    Raises :class:`DegenerateAlignment` for a scale when their covariance is 0."""
    x, y = np.asarray(src, float), np.asarray(dst, float)
    if x.shape != y.shape or x.ndim != 2 or len(x) < 3:
        raise ValueError(f"need two (N, 3) arrays with N >= 3, got {x.shape} and {y.shape}")
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    var_x = np.mean(np.sum(xc * xc, axis=1))  # eq. 36
    cov = yc.T @ xc / len(x)  # eq. 38
    U, d, Vt = np.linalg.svd(cov)
    if with_scale and not np.any(d > np.finfo(float).eps):  # evo's rank test, at rank 0
        raise DegenerateAlignment("one of the trajectories does not move (e.g. standing "
                                  "still): a similarity alignment is undetermined")
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:  # eq. 39: a reflection, not a rotation
        S[2, 2] = -1.0
    R = U @ S @ Vt  # eq. 40
    s = float(np.trace(np.diag(d) @ S) / var_x) if with_scale else 1.0  # eq. 42
    t = my - s * R @ mx  # eq. 41
    return R, t, s


def alignment(est: np.ndarray, ref: np.ndarray, mode: Align = "none"
              ) -> tuple[np.ndarray, np.ndarray, float]:
    """``(R, t, s)`` mapping estimated positions ``(N, 3)`` onto the reference ones."""
    if mode == "none":
        return np.eye(3), np.zeros(3), 1.0
    if mode not in ALIGNMENTS:
        raise ValueError(f"unknown alignment {mode!r}; use one of {', '.join(ALIGNMENTS)}")
    return umeyama(est, ref, with_scale=mode == "sim3")


def apply_alignment(T: np.ndarray, R: np.ndarray, t: np.ndarray, s: float) -> np.ndarray:
    """Poses ``(N, 4, 4)`` moved by the similarity ``(R, t, s)``: positions ``s R p + t``,
    orientations ``R R_i`` (as evo's ``align``)."""
    out = np.array(T, float, copy=True)
    out[:, :3, 3] = s * T[:, :3, 3] @ R.T + t
    out[:, :3, :3] = R @ T[:, :3, :3]
    return out
