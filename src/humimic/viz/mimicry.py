"""What mimicry shows: its PNG plots and its rerun series (the scores are
:mod:`humimic.metrics.mimicry_report`'s).

Rerun entities (all against ``sim_time``):

* ``series/mimicry/<site>/error_mm``: the robot site minus the mapped truth per base axis
  (``x error``, ``y error``, ``z error``) and its norm, mm -- the default layout's panel;
* ``series/mimicry/<site>/position_m/{x,y,z}``: mapped truth, command and robot, m;
* ``series/robot_joints/<joint>``: the IK's joint target and the actual angle, rad;
* ``world/mimic/{commanded,reached}``: command and reached site in 3-D; ``world/mimic/gaze``.
"""

from __future__ import annotations

import numpy as np

from humimic.metrics.mimicry import TERMS
from humimic.metrics.mimicry_report import (
    MIN_TICKS,
    aligned_rows,
    series_blocks,
    site_budget,
    site_series,
)
from humimic.viz.rerun_columns import SERIES_CHUNK
from humimic.viz.rerun_log import AXIS_RGB, SERIES
from humimic.world.names import ROBOT_JOINTS

#: The default layout's time-series root of mimicry.
MIMICRY = f"{SERIES}/mimicry"


def _scored(stage):
    """``(site index, channel, aligned rows)`` of every site with enough mimicry to score."""
    for i, ch in enumerate(stage.channels):
        if ch.started:
            m = aligned_rows(stage, i)[1]
            if m >= MIN_TICKS:
                yield i, ch, m


def mimic_plots(stage, out_dir) -> list:
    """``mimic_<site>.png`` (truth, estimate, command, robot) and ``mimic_error_budget.png``."""
    from humimic.viz.plots import MAX_POINTS, plot_error_budget, plot_trajectories

    paths, rms, shares, totals, sites = [], {}, {}, [], []
    for i, ch, m in _scored(stage):
        # only the rows drawn (every k-th, as plot_trajectories would take them)
        _, s = site_series(stage, i, ch, ("t", "true_now", "est", "cmd", "robot"),
                           slice(None, None, max(1, -(-m // MAX_POINTS))))
        paths.append(plot_trajectories(
            f"{out_dir}/mimic_{ch.site}.png", s["t"],
            {f"{ch.target} true (mapped)": s["true_now"], f"{ch.target} estimate": s["est"],
             f"{ch.site} commanded": s["cmd"], f"{ch.site} robot": s["robot"]},
            title=f"{ch.target} -> {ch.site}: displacement, robot base frame", ylabel="m"))
        term_rms, share, _ = site_budget(stage, i, ch)  # summed block by block
        sites.append(ch.site)
        totals.append(1e3 * term_rms["total"])
        for term in TERMS:
            rms.setdefault(term, []).append(1e3 * term_rms[term])
            shares.setdefault(term, []).append(share[term])
    if sites:
        paths.append(plot_error_budget(f"{out_dir}/mimic_error_budget.png", sites, rms, shares,
                                       totals))
    return paths


def log_mimicry(stage, rlog) -> None:
    """The series and 3-D points of the module docstring."""
    if rlog is None or not rlog.enabled:
        return
    rec = stage.rec
    n = rec.n
    t = rec.t[:n]
    for j, name in enumerate(ROBOT_JOINTS):
        rlog.log_series(f"{SERIES}/robot_joints/{name}", t,
                        np.stack([rec.q_ik[:n, j], rec.q_robot[:n, j]], axis=1),
                        names=[f"{name} target (rad)", f"{name} actual (rad)"])
    for i, ch, _ in _scored(stage):
        root = f"{MIMICRY}/{ch.site}"
        # a chunk's rows at a time (log_series sends the same chunks as for the whole series)
        for s in series_blocks(stage, i, ch, ("t", "true_now", "cmd", "robot"), SERIES_CHUNK):
            err = 1e3 * (s["robot"] - s["true_now"])
            rlog.log_series(f"{root}/error_mm", s["t"],
                            np.column_stack([err, np.linalg.norm(err, axis=1)]))
            for a, axis in enumerate("xyz"):
                rlog.log_series(f"{root}/position_m/{axis}", s["t"], np.stack(
                    [s["true_now"][:, a], s["cmd"][:, a], s["robot"][:, a]], axis=1))
        rlog.set_series_names(f"{root}/error_mm",
                              [f"{a} error (mm)" for a in "xyz"] + ["|error| (mm)"],
                              colors=[*AXIS_RGB, (30, 30, 30)], widths=[1.0, 1.0, 1.0, 2.0])
        for axis in "xyz":
            rlog.set_series_names(f"{root}/position_m/{axis}",
                                  [f"{axis} {ch.target} true, mapped (m)",
                                   f"{axis} commanded (m)", f"{axis} {ch.site} robot (m)"])
    ks = np.arange(0, n, max(1, int(round(1.0 / (30.0 * rec.dt)))))  # 30 Hz
    for k0 in range(0, len(ks), SERIES_CHUNK):  # as columns (one log call a row: see
        kb = ks[k0:k0 + SERIES_CHUNK]          # humimic.viz.rerun_columns), a block at a time
        t_k = t[kb]
        rlog.log_points_rows("world/mimic/commanded", t_k, stage.to_world(rec.p_cmd[kb]),
                             colors=[255, 160, 0], radii=0.015)
        rlog.log_points_rows("world/mimic/reached", t_k, stage.to_world(rec.p_robot[kb]),
                             colors=[0, 200, 255], radii=0.012)
        if stage.gaze is not None:
            cam_mat = rec.cam_mat[kb].reshape(len(kb), 2, 3, 3)
            rlog.log_arrows_rows("world/mimic/gaze", t_k, rec.cam_pos[kb],
                                 cam_mat[:, :, :, 2] * -1.5,  # camera -z, 1.5 m
                                 colors=[[255, 0, 255], [255, 0, 255]])

