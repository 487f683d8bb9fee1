"""Sugiyama & Miura's movement-estimation results as tables (Table II, Fig. 8, cycle times),
computed from SLAM runs (``slam.npz`` / :meth:`SlamStage.trajectories`) beside the paper's.

The paper compares the estimated interface position (the head camera) with where the user
stood (Table II); the head camera is ahead of the point between the feet and moves as the head
looks around, so both are given here: the error against the true head (what the filter
estimates) and against the stand point (the paper's comparison).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.maths.stats import rmse

#: Table II: user's position (x_u, z_u), estimated (x_I, z_I), error (m).
PAPER_TABLE2 = (((1.25, -2.50), (1.22, -2.32), 0.18), ((1.25, 0.00), (1.31, 0.07), 0.09),
                ((0.00, -2.50), (0.19, -2.43), 0.20), ((-1.25, 0.00), (-1.03, -0.09), 0.24))
#: Sec. V-A: mean cycle time (ms) with 20 and 40 features in the map (1.33 GHz Core 2 Duo).
PAPER_CYCLE_MS = {20: 36.7, 40: 43.3}
#: Fig. 8 in words: what each way of estimating did during the jump.
PAPER_FIG8 = {"fusion": "estimated successfully",
              "camera": "all features fail to match",
              "inertial": "pose wrong: sensor drift accumulates"}


@dataclass(frozen=True)
class Stand:
    """An interval during which the person stands at ``at`` ((x, z) in W, m)."""

    t0: float
    t1: float
    at: tuple[float, float]


def standing_intervals(waypoints: list[tuple[float, tuple[float, float]]]) -> list[Stand]:
    """Intervals between consecutive waypoints ``(t, (x, z))`` at the same place (the person
    stands there)."""
    out = []
    for (ta, a), (tb, b) in zip(waypoints[:-1], waypoints[1:], strict=True):
        if np.allclose(a, b) and tb > ta:
            out.append(Stand(float(ta), float(tb), (float(a[0]), float(a[1]))))
    return out


@dataclass(frozen=True)
class Table2Row:
    user: tuple[float, float]
    paper_est: tuple[float, float]
    paper_err: float
    head: np.ndarray
    """(2,) true head (x, z) averaged over the stand (m)."""
    est: np.ndarray
    """(2,) estimated head (x, z) averaged over the stand (m)."""
    err_head: float
    """|mean over the stand of the per-frame error| against the true head (m)."""
    err_user: float
    """|est - user|: the paper's comparison (m)."""
    rms_head: float
    """RMS over the stand's frames of the horizontal error against the true head (m)."""
    frames: int


def table2(tr: dict, stands: list[Stand], settle_s: float = 0.3) -> list[Table2Row]:
    """One row per position of the paper's Table II that the run stood at (the last visit),
    over the stand's frames after ``settle_s``."""
    t = tr["t"]
    xz_est, xz_true = tr["p"][:, [0, 2]], tr["p_true"][:, [0, 2]]
    rows = []
    for user, paper_est, paper_err in PAPER_TABLE2:
        visits = [s for s in stands if np.allclose(s.at, user)]
        if not visits:
            continue
        s = visits[-1]
        sel = (t >= s.t0 + settle_s) & (t <= s.t1)
        if not sel.any():
            continue
        est, head = xz_est[sel].mean(axis=0), xz_true[sel].mean(axis=0)
        e = xz_est[sel] - xz_true[sel]
        rows.append(Table2Row(user, paper_est, paper_err, head, est,
                              float(np.linalg.norm(e.mean(axis=0))),
                              float(np.linalg.norm(est - np.asarray(user))),
                              rmse(e), int(sel.sum())))
    return rows


def format_table2(rows: list[Table2Row]) -> str:
    head = (f"{'user (x, z)':>15} | {'paper est.':>15} {'err':>5} | {'true head':>15} "
            f"{'estimated':>15} {'err head':>8} {'rms':>6} {'err user':>8}")
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{_xz(r.user):>15} | {_xz(r.paper_est):>15} {r.paper_err:5.2f} | "
            f"{_xz(r.head):>15} {_xz(r.est):>15} {r.err_head:8.3f} {r.rms_head:6.3f} "
            f"{r.err_user:8.3f}")
    return "\n".join(lines)


def _xz(v) -> str:
    return f"({v[0]:+.2f}, {v[1]:+.2f})"


def fig8_row(metrics: dict) -> dict:
    """The Fig. 8 numbers of one run's ``slam`` metrics."""
    keys = ("ate_rmse_m", "vertical_rmse_m", "position_max_error_m", "heading_rmse_deg",
            "features_per_frame", "frames_without_features")
    return {k: metrics.get(k) for k in keys}
