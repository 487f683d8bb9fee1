"""PNG plots of a SLAM run: the head's path seen from above and its error over time."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from humimic.estimation.ekf.slam_record import pose_errors
from humimic.world.frames import SCREEN_CORNERS_W


def plot_trajectory(path: Path, tr: dict, title: str = "Head camera (frame I) in W") -> Path:
    """Top view (x, z of the paper's W: Table II's plane) of the estimated and true head
    positions with the screen, beside the position and heading errors over time."""
    import matplotlib.pyplot as plt

    e = pose_errors(tr["p"], tr["q"], tr["p_true"], tr["R_true"])
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.6), gridspec_kw={"width_ratios": [1, 1.3]})
    ax.plot(tr["p_true"][:, 0], tr["p_true"][:, 2], color="tab:green", lw=2, label="true")
    ax.plot(tr["p"][:, 0], tr["p"][:, 2], color="tab:red", lw=1, label="estimated")
    s = SCREEN_CORNERS_W
    ax.plot([s[0, 0], s[1, 0]], [s[0, 2], s[1, 2]], color="k", lw=4, label="screen")
    ax.set_xlabel("x_W (m, left)")
    ax.set_ylabel("z_W (m, towards the screen)")
    ax.invert_xaxis()  # x points left: draw it as a person facing the screen sees the floor
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title, fontsize=10)
    t = tr["t"]
    ax2.plot(t, 100 * np.linalg.norm(e["position"], axis=1), color="tab:red",
             label="position error (cm)")
    sd = 100 * np.sqrt(np.maximum(np.trace(tr["P"][:, 0:3, 0:3], axis1=1, axis2=2), 0))
    ax2.fill_between(t, 0, 2 * sd, color="tab:red", alpha=0.15, label="2 sigma (cm)")
    ax2.plot(t, np.degrees(np.abs(e["heading"])), color="tab:blue", label="|heading error| (deg)")
    ax2.plot(t, tr["measured"], color="0.5", lw=0.8, label="features measured")
    ax2.set_xlabel("time (s)")
    ax2.grid(alpha=0.3)
    ax2.legend(loc="upper right", fontsize=8)
    ax2.set_ylim(bottom=0)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def plot_table2(path: Path, rows) -> Path:
    """Sugiyama & Miura's Table II beside this run's numbers, as an image for the report."""
    import matplotlib.pyplot as plt

    def xz(v):
        return f"({v[0]:+.2f}, {v[1]:+.2f})"

    cells = [[xz(r.user), xz(r.paper_est), f"{r.paper_err:.2f}", xz(r.head), xz(r.est),
              f"{100 * r.err_head:.1f}", f"{100 * r.err_user:.1f}"] for r in rows]
    cols = ["user (x, z) m", "paper: estimated", "paper: error m", "true head",
            "estimated head", "error cm", "error vs user cm"]
    fig, ax = plt.subplots(figsize=(11, 0.45 * len(rows) + 0.9))
    ax.axis("off")
    table = ax.table(cellText=cells, colLabels=cols, loc="center", cellLoc="center")
    table.auto_set_font_size(False)
    table.set_fontsize(9)
    table.scale(1.0, 1.3)
    ax.set_title("Table II: the user's position and the estimated interface position in W "
                 "(ours averaged over each stand)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
