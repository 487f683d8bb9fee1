"""Scores and the Fig. 10 plot of the commands and the robot following them.

``metrics.json`` ``commands``: how many commands of each kind went out; per kind the time from
issue to finished (``execution_s_mean``) and how far the robot is from the wearer's *true*
state once a command has finished (the base from the wearer's displacement, the head's pan and
tilt from the wearer's, the palm from the wearer's remote mapped as the commands map it); the
path lag (the time shift that best aligns the robot's path with the wearer's: a lag, not a
latency) and the age of the estimate a command was made from.
"""

from __future__ import annotations

import numpy as np

from humimic.control import commands as cmds
from humimic.estimation.ekf.arm_record import truth_in_head
from humimic.maths.stats import finite_or_none, rmse


def true_targets(gt, t: np.ndarray, p_eyes_base: np.ndarray) -> dict[str, np.ndarray]:
    """The command targets the wearer's true motion gives at times ``t`` (N,)."""
    k = gt.index_of(np.asarray(t, float))
    T = gt.pose("headcam", "W")
    p0 = T[0, :3, 3]
    p_I, _ = truth_in_head(gt, t)
    return {
        "move": np.array([cmds.movement_target(T[i, :3, 3], p0) for i in k]),
        "head": np.array([cmds.head_angles(T[i, :3, :3]) for i in k]),
        "arm": np.array([cmds.arm_target(p, T[i, :3, :3], p_eyes_base)
                         for p, i in zip(p_I, k, strict=True)]),
    }


def path_lag(t: np.ndarray, robot: np.ndarray, user: np.ndarray, max_lag: float = 10.0
             ) -> float:
    """The delay ``tau`` (s, >= 0) minimising the RMS of ``robot(t) - user(t - tau)``."""
    if len(t) < 3:
        return float("nan")
    dt = float(np.median(np.diff(t)))
    best, best_tau = np.inf, float("nan")
    for s in range(0, int(max_lag / dt)):
        if len(t) - s < len(t) // 2:
            break
        e = rmse(robot[s:] - user[: len(t) - s])
        if e < best:
            best, best_tau = e, s * dt
    return best_tau


def _robot_state(rec: dict, kind: str) -> np.ndarray:
    return {"move": rec["base"][:, :2], "head": rec["head"], "arm": rec["palm"]}[kind]


def commands_metrics(cmd_stage, follow) -> dict:
    gt = cmd_stage.world.gt
    rec = follow.rec.arrays()
    out: dict = {"count": {k: cmd_stage.seq[k] for k in cmd_stage.cfg.kinds}}
    if len(rec["t"]) == 0:
        return {"commands": out}
    truth = true_targets(gt, rec["t"], cmd_stage.p_eyes_base)
    done = {(c.kind, c.seq): t for t, c in follow.rec.done}
    units = {"move": ("position_error_after", "m", 1.0),
             "head": ("angle_error_after", "deg", np.degrees(1.0)),
             "arm": ("palm_error_after", "m", 1.0)}
    for kind in cmd_stage.cfg.kinds:
        issued = [(ts, ti, c) for ts, ti, c in cmd_stage.issued if c.kind == kind]
        robot = _robot_state(rec, kind)
        errs, execs = [], []
        for _, ti, c in issued:
            td = done.get((kind, c.seq))
            if td is None:
                continue
            execs.append(td - ti)
            i = min(int(np.searchsorted(rec["t"], td)), len(rec["t"]) - 1)
            errs.append(float(np.linalg.norm(robot[i] - truth[kind][i])))
        name, unit, scale = units[kind]
        out[kind] = {
            "count": len(issued),
            "finished": len(execs),
            "execution_s_mean": finite_or_none(np.mean(execs) if execs else np.nan),
            f"{name}_{unit}_mean": finite_or_none(scale * np.mean(errs) if errs else np.nan),
            f"{name}_{unit}_max": finite_or_none(scale * np.max(errs) if errs else np.nan),
            f"final_error_{unit}": finite_or_none(scale * np.linalg.norm(robot[-1]
                                                                         - truth[kind][-1])),
            "path_lag_s": finite_or_none(path_lag(rec["t"], robot, truth[kind])),
            "estimate_age_ms": finite_or_none(1e3 * np.mean([ti - ts for ts, ti, _ in issued])
                                              if issued else np.nan),
        }
    return {"commands": out}


def commands_plot(cmd_stage, follow, path) -> list:
    """Sugiyama Fig. 10: the wearer's and the robot's paths from above, the targets against
    time with the commands, the head and the palm (PNG)."""
    import matplotlib.pyplot as plt

    rec = follow.rec.arrays()
    if len(rec["t"]) == 0:
        return []
    t = rec["t"]
    truth = true_targets(cmd_stage.world.gt, t, cmd_stage.p_eyes_base)
    est_t = np.array([x[0] for x in cmd_stage.targets])
    est = {k: np.array([x[1][k] for x in cmd_stage.targets if k in x[1]])
           for k in cmd_stage.cfg.kinds}
    issued = {k: [(ti, c.target) for _, ti, c in cmd_stage.issued if c.kind == k]
              for k in cmd_stage.cfg.kinds}
    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    ax = axes[0, 0]  # from above: R's y to the left, x up
    ax.plot(-truth["move"][:, 1], truth["move"][:, 0], "k-", lw=1.5, label="wearer (true)")
    if "move" in est and len(est["move"]):
        ax.plot(-est["move"][:, 1], est["move"][:, 0], "C0-", lw=0.8, label="wearer (estimated)")
    ax.plot(-rec["base"][:, 1], rec["base"][:, 0], "C3-", lw=1.5, label="robot")
    for _, tgt in issued.get("move", []):
        ax.plot(-tgt[1], tgt[0], "C3x", ms=8)
    ax.set_xlabel("-y_R (right) [m]")
    ax.set_ylabel("x_R (forward) [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    ax.set_title("displacement since the start (x: move commands)")
    ax = axes[0, 1]
    for i, (lab, c) in enumerate((("x_R", "C0"), ("y_R", "C2"))):
        ax.plot(t, truth["move"][:, i], c + "--", lw=1, label=f"wearer {lab}")
        ax.plot(t, rec["base"][:, i], c + "-", lw=1.5, label=f"robot {lab}")
    for ti, _ in issued.get("move", []):
        ax.axvline(ti, color="C3", lw=0.6, alpha=0.6)
    ax.set_ylabel("[m]")
    ax.legend(fontsize=8, ncol=2)
    ax.set_title("base (vertical lines: move commands)")
    ax = axes[1, 0]
    for i, (lab, c) in enumerate((("pan", "C0"), ("tilt", "C1"))):
        ax.plot(t, np.degrees(truth["head"][:, i]), c + "--", lw=1, label=f"wearer {lab}")
        ax.plot(t, np.degrees(rec["head"][:, i]), c + "-", lw=1.5, label=f"robot {lab}")
    for ti, _ in issued.get("head", []):
        ax.axvline(ti, color="C1", lw=0.6, alpha=0.5)
    ax.set_ylabel("[deg]")
    ax.set_xlabel("time [s]")
    ax.legend(fontsize=8, ncol=2)
    ax.set_title("head")
    ax = axes[1, 1]
    for i, (lab, c) in enumerate((("x", "C0"), ("y", "C2"), ("z", "C4"))):
        ax.plot(t, truth["arm"][:, i], c + "--", lw=1, label=f"wearer's remote {lab}")
        ax.plot(t, rec["palm"][:, i], c + "-", lw=1.5, label=f"robot palm {lab}")
        if "arm" in est and len(est["arm"]):
            ax.plot(est_t[-len(est["arm"]):], est["arm"][:, i], c + ":", lw=0.8)
    for ti, _ in issued.get("arm", []):
        ax.axvline(ti, color="C4", lw=0.6, alpha=0.5)
    ax.set_ylabel("base frame [m]")
    ax.set_xlabel("time [s]")
    ax.legend(fontsize=7, ncol=2)
    ax.set_title("right arm (dotted: estimated target)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]
