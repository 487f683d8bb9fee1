"""The mimic stage's ``metrics.json`` sections, from its record and the ground truth.

``mimicry.<robot_site>``: ``rmse_mm`` between the site's displacement and the human part's true
displacement after the mapping, ``lag_ms`` (cross-correlation peak: a lag, not a delay),
``jerk`` (RMS third derivative, m/s^3; ``jerk_human`` for the mapped truth),
``mapped_motion_rms_mm`` (the mapped truth's RMS distance from its mean, after the mapping's
scale: what there was to copy; a run's warning line names a site under
:data:`STILL_TARGET_MM`), ``joint_limit_hits`` (servo ticks at which an arm or torso joint
target sits on the IK's limit band; ``joint_limit_hits_by_joint`` per joint),
``clamped_fraction``;

* ``status``: ``ok``, or ``lost_often`` (with a ``reason``) when ``lost_fraction`` (ticks
  with an estimate older than the stage's ``MAX_AGE``) exceeds ``LOST_OFTEN`` (25 %; unscored:
  ``never_detected``, ``not_started``, ``too_short``);
* ``error_budget_mm``: the RMS of each stage term of :func:`~humimic.metrics.mimicry.error_terms`
  (``estimate``, ``pipeline_delay``, ``fresh_hold``, ``stale_hold``, ``interpolation``,
  ``workspace``, ``ik``, ``servo``) and of their sum, ``total`` (= ``rmse_mm``). The terms
  add up to the total as vectors, at every instant; their RMS values do not (they partly
  cancel). ``error_budget_share``: each term's share of the total's mean square
  (:func:`~humimic.metrics.mimicry.mse_shares`; adds up to 1);
* ``measurements_rmse_mm`` / ``estimates_rmse_mm``: separate RMS errors, not budget terms, of
  the raw 3-D measurements (tracked perception only; None with the oracle, which measures
  nothing) and of the estimates that arrived, each against the truth at its photon time;
* ``interpolation``: hold vs extrapolate commands against the truth;
* ``scale``: the mapping's scale in use at the end (``scale_initial`` at the start; the mapped
  truth is scaled by the scale in use at each tick), ``strained_fraction``: servo ticks at
  which the fit found the arm strained (:mod:`humimic.control.mapping`).

``mimicry.head_still``, ``mimicry.gaze`` and ``mimicry.ik`` complete it; ``latency_ms`` holds
true delays in simulated time (photon to the first servo tick that used a frame) and
``lag_ms`` the cross-correlation lags behind the truth (:func:`latency_metrics`,
:func:`lag_metrics`).
"""

from __future__ import annotations

from functools import partial

import numpy as np

from humimic import spill
from humimic.control.ik import on_limit_band
from humimic.control.stage import MAX_AGE
from humimic.maths.stats import finite_or_none as _num
from humimic.maths.stats import rms_of, rmse, sum_squares
from humimic.metrics import mm as _mm
from humimic.metrics.mimicry import (
    TERMS,
    add_budget_sums,
    budget_from_sums,
    budget_sums,
    error_terms,
    head_motion,
    image_offsets,
    lost_status,
    rms_jerk,
    stale_time,
    summary_stats,
    xcorr_lag,
)
from humimic.sensors.camera_model import R_MJCAM_CV, Intrinsics
from humimic.spill import row_blocks
from humimic.world.names import ROBOT_JOINTS, TORSO_JOINTS

#: A mapped human part moving less than this (RMS about its mean, mm) gives the robot nothing to
#: copy: the run's warning line names the site (e.g. the mapping left on ``right_hand`` while
#: the person waves the left).
STILL_TARGET_MM = 10.0

#: Joints whose limits matter for a site (its arm and the torso).
ARM_JOINTS = {
    "R": ("R_SFE", "R_SAA", "R_HR", "R_EB", "R_WR", "R_WFE", "R_WAA"),
    "L": ("L_SFE", "L_SAA", "L_HR", "L_EB", "L_WR", "L_WFE", "L_WAA"),
}
#: Fewest servo ticks of mimicry worth scoring.
MIN_TICKS = 30


def _idx(times: np.ndarray, rate: float, n: int) -> np.ndarray:
    return np.clip(np.rint(np.asarray(times) * rate).astype(int), 0, n - 1)


def _never_started(stage, ch) -> dict:
    rec, cfg = stage.rec, stage.cfg
    got = len(rec.estimates.get(ch.target, ()).t) if ch.target in rec.estimates else 0
    if got == 0:
        why = (f"no estimate of human target {ch.target!r} arrived during the run; "
               + ("the oracle never had it inside every eye camera's image"
                  if cfg.perception == "oracle" else
                  "perception never reported it (is it among the perception targets and "
                  "visible?)"))
        status = "never_detected"
    else:
        why = (f"{got} estimates of {ch.target!r} arrived, none with a photon time at or after "
               f"mimic.start = {cfg.start} s")
        status = "not_started"
    i = stage.sites.index(ch.site)
    p = rec.p_robot[:rec.n, i]
    moved = float(np.max(np.linalg.norm(p - ch.p0_robot, axis=1))) if rec.n else 0.0
    return {"status": status, "reason": why, "target": ch.target, "rmse_mm": None,
            "lag_ms": None, "held_pose": True, "robot_max_displacement_mm": 1e3 * moved}


#: Every series of :func:`site_series`.
SERIES_KEYS = ("t", "true_now", "true_photon", "true_ready", "true_stale", "est", "cmd_raw",
               "cmd", "cmd_alt", "ik", "robot")


def aligned_rows(stage, i: int) -> tuple[int, int]:
    """``(k0, m)``: the record's row at which site ``i`` started and the length of its aligned
    series (:func:`site_series`)."""
    rec = stage.rec
    k0 = int(np.argmax(rec.active[:rec.n, i]))
    return k0, max(rec.n - 1 - k0, 0)


def site_series(stage, i: int, ch, keys: tuple[str, ...] = SERIES_KEYS,
                rows: slice = slice(None)):
    """Aligned displacement series of site ``i`` from the tick after it started: the robot at
    ``t[k]`` with the command, IK and estimate computed for ``t[k-1] + dt = t[k]``. Only the
    series named in ``keys`` are gathered, and only their ``rows`` (a slice of the aligned
    series: a long run's columns are tens of MB each)."""
    rec, world = stage.rec, stage.world
    k0, m = aligned_rows(stage, i)
    a, b, step = rows.indices(m)
    now, before = slice(k0 + 1 + a, k0 + 1 + b, step), slice(k0 + a, k0 + b, step)
    rate = world.scenario.timing.physics_rate
    N = len(world.gt.t)

    def truth(times) -> np.ndarray:  # the ground truth only at the ticks used
        k = _idx(times, rate, N)
        p = world.gt.p_base(ch.target)[k]
        return p - world.gt.p_base(ch.ref)[k] if ch.ref is not None else p

    M, p0r = ch.M, ch.p0_robot
    origin = truth(ch.t0)

    def mapped_truth(times) -> np.ndarray:
        return rec.scale[before, i, None] * ((truth(times) - origin) @ M.T)

    series = {
        "t": lambda: rec.t[now],
        "true_now": lambda: mapped_truth(rec.t[now]),
        "true_photon": lambda: mapped_truth(rec.t_est[before, i]),
        "true_ready": lambda: mapped_truth(rec.t_ready[before, i]),
        "true_stale": lambda: mapped_truth(stale_time(rec.t[now], rec.t_est[before, i],
                                                      rec.t_ready[before, i], MAX_AGE)),
        "est": lambda: rec.p_est[before, i] - p0r,
        "cmd_raw": lambda: rec.p_cmd_raw[before, i] - p0r,
        "cmd": lambda: rec.p_cmd[before, i] - p0r,
        "cmd_alt": lambda: rec.p_cmd_alt[before, i] - p0r,
        "ik": lambda: rec.p_ik[before, i] - p0r,
        "robot": lambda: rec.p_robot[now, i] - p0r,
    }
    return k0, {key: series[key]() for key in keys}


def series_blocks(stage, i: int, ch, keys: tuple[str, ...], block: int | None = None):
    """:func:`site_series`' ``keys``, ``block`` rows (default: the record's
    :data:`~humimic.spill.BLOCK`) at a time (reductions over a long run)."""
    _, m = aligned_rows(stage, i)
    block = block or spill.BLOCK
    for a in range(0, m, block):
        yield site_series(stage, i, ch, keys, slice(a, a + block))[1]


def site_budget(stage, i: int, ch) -> tuple[dict[str, float], dict[str, float], float]:
    """:func:`~humimic.metrics.mimicry.budget_from_sums` of site ``i``'s error terms, summed
    block by block (m; the whole run's values to rounding)."""
    sums = None
    for s in series_blocks(stage, i, ch, SERIES_KEYS[1:]):
        sums = add_budget_sums(sums, budget_sums(error_terms(
            s["true_now"], s["true_photon"], s["true_ready"], s["true_stale"], s["est"],
            s["cmd_raw"], s["cmd"], s["ik"], s["robot"])))
    return budget_from_sums(sums if sums is not None else budget_sums(
        {name: np.zeros((0, 3)) for name in (*TERMS, "total")}))


def _scale_at(stage, i: int, ch, t: np.ndarray) -> np.ndarray:
    """``(N, 1)`` mapping scale of site ``i`` in use at times ``t`` (its first before it
    started)."""
    rec = stage.rec
    active = rec.active[:rec.n, i]
    ts, ss = rec.t[:rec.n][active], rec.scale[:rec.n, i][active]
    if len(ts) == 0:
        return np.full((len(t), 1), ch.scale)
    return np.interp(t, ts, ss)[:, None]


def _event_error(arrivals, P: np.ndarray, M: np.ndarray, scale_at, rate: float,
                 t_start: float) -> float | None:
    """RMS (mm, mapped space: reflection ``M``, the scale at each photon time from
    ``scale_at(t)``) of the values that arrived on a topic, photon times from ``t_start`` on,
    against the truth at their photon times (None if there are none)."""
    if arrivals is None or not arrivals.t:
        return None
    t, _, p = arrivals.arrays()
    keep = t >= t_start - 1e-9
    if not np.any(keep):
        return None
    return _mm(rmse(scale_at(t[keep]) * ((p[keep] - P[_idx(t[keep], rate, len(P))]) @ M.T)))


def _limit_hits(stage, site: str, k0: int) -> tuple[int, dict[str, int]]:
    """Servo ticks at which a joint of the site's arm or the torso sits on the IK's limit band,
    and the ticks per joint (joints that never touch theirs are left out)."""
    rec = stage.rec
    names = ARM_JOINTS[site[0]] + TORSO_JOINTS
    j = np.array([ROBOT_JOINTS.index(x) for x in names])
    ticks, per = 0, np.zeros(len(j), int)
    for q in row_blocks(rec.q_ik, k0, rec.n):  # a block of rows at a time: 60 MB at 10 min
        hit = on_limit_band(q[:, j], stage.ik_model.jnt_range[j], stage.cfg.ik.limit_margin)
        ticks += int(np.any(hit, axis=1).sum())
        per += hit.sum(axis=0)
    return ticks, {name: int(n) for name, n in zip(names, per, strict=True) if n}


def site_metrics(stage, i: int, ch) -> tuple[dict, dict]:
    """``(cumulative lags per stage (ms), the site's scores)``. RMS values and shares are
    summed block by block (:func:`site_budget`); lags and jerk need whole series, gathered
    one beside the truth at a time."""
    if not ch.started:
        return {}, _never_started(stage, ch)
    rec, world, cfg = stage.rec, stage.world, stage.cfg
    k0, m = aligned_rows(stage, i)
    if m < MIN_TICKS:
        return {}, {"status": "too_short", "target": ch.target, "rmse_mm": None,
                    "lag_ms": None, "reason": f"mimicry ran {m} servo ticks; scores "
                                              f"need at least {MIN_TICKS}"}
    dt = rec.dt
    rate = world.scenario.timing.physics_rate
    P = world.gt.p_base(ch.target)
    scale_at = partial(_scale_at, stage, i, ch)
    rms, share, top = site_budget(stage, i, ch)
    budget = {name: _mm(v) for name, v in rms.items()}
    shares = {k: _num(v) for k, v in share.items()}
    primary, other = cfg.interpolation.mode, ("extrapolate" if cfg.interpolation.mode == "hold"
                                              else "hold")
    sq = {key: [0.0, 0] for key in ("cmd", "cmd_alt")}
    for s in series_blocks(stage, i, ch, ("true_now", "cmd", "cmd_alt")):
        for key, acc in sq.items():
            total, count = sum_squares(s[key] - s["true_now"])
            acc[0] += total
            acc[1] += count
    _, s = site_series(stage, i, ch, ("true_now", "robot"))

    def lag(key: str) -> float:  # one more whole series at a time
        return _mm(xcorr_lag(s["true_now"], site_series(stage, i, ch, (key,))[1][key], dt))

    interp = {mode: {"rmse_mm": _mm(rms_of(*sq[key])), "lag_ms": lag(key)}
              for mode, key in ((primary, "cmd"), (other, "cmd_alt"))}
    n_active = rec.n - k0
    hits, hits_by_joint = _limit_hits(stage, ch.site, k0)
    stage_lags = {"interpolation": interp[primary]["lag_ms"], "ik": lag("ik")}
    lost = float(rec.lost[k0:rec.n, i].mean())
    return stage_lags, {
        **lost_status(lost, ch.target, MAX_AGE),
        "target": ch.target,
        "rmse_mm": budget["total"],
        "lag_ms": _mm(xcorr_lag(s["true_now"], s["robot"], dt)),
        "max_error_mm": _mm(top),
        "jerk": _num(rms_jerk(s["robot"], dt)),
        "jerk_human": _num(rms_jerk(s["true_now"], dt)),
        "mapped_motion_rms_mm": _mm(rmse(s["true_now"] - np.nanmean(s["true_now"], axis=0))),
        "joint_limit_hits": hits,
        "joint_limit_hits_by_joint": hits_by_joint,
        "clamped_fraction": float(rec.clamped[k0:rec.n, i].mean()),
        "scale": ch.scale,
        "scale_initial": ch.scale_initial,
        "strained_fraction": (ch.fit.strained_ticks / n_active if ch.fit is not None
                              else None),
        "lost_fraction": lost,
        "started_s": float(rec.t[k0]),
        "ticks": int(n_active),
        "error_budget_mm": budget,
        "error_budget_share": shares,
        "measurements_rmse_mm": _event_error(rec.measurements.get(ch.target), P, ch.M,
                                             scale_at, rate, ch.t0),
        "estimates_rmse_mm": _event_error(rec.estimates.get(ch.target), P, ch.M, scale_at,
                                          rate, ch.t0),
        "interpolation": interp,
    }


def gaze_metrics(stage) -> dict | None:
    cfg = stage.cfg.gaze
    if not cfg.enabled:
        return None
    rec, world = stage.rec, stage.world
    n = rec.n
    if cfg.target not in rec.estimates:
        return {"target": cfg.target, "status": "never_detected"}
    t_first = rec.estimates[cfg.target].t[0]
    k0 = int(np.searchsorted(rec.t[:n], t_first))
    m, scene = world.scene.model, world.scene
    w, h = world.scenario.cameras.resolution
    rate = world.scenario.timing.physics_rate
    Pw = world.gt.p_world(cfg.target)
    p = Pw[_idx(rec.t[k0:n], rate, len(Pw))]
    out = {"target": cfg.target, "camera": cfg.camera, "status": "ok",
           "eye_saturated_ticks": int(stage.gaze.saturated)}
    worst = np.zeros(n - k0)
    for e, eye in enumerate(("L", "R")):
        cid = scene.camera(f"{eye}_{cfg.camera}")
        intr = Intrinsics.from_fovy(np.radians(m.cam_fovy[cid]), w, h)
        R = rec.cam_mat[k0:n, e].reshape(-1, 3, 3)
        p_cam = np.einsum("nji,nj->ni", R, p - rec.cam_pos[k0:n, e]) @ R_MJCAM_CV.T
        off = image_offsets(p_cam, intr.fx, intr.fy, w, h)
        out[f"{eye}_offset_frac"] = summary_stats(off)
        worst = np.maximum(worst, off)
    out["within_10pct_fraction"] = float(np.mean(worst <= 0.1)) if len(worst) else None
    out["max_offset_frac"] = float(worst.max()) if len(worst) and np.isfinite(worst.max()) \
        else None
    return out


def latency_metrics(stage) -> dict:
    """True delays (ms of simulated time), means over the values that arrived:

    * ``perception``: photon time -> measurement ready (tracked perception only);
    * ``filter``: measurement ready -> estimate ready (tracked perception only);
    * ``estimate``: photon time -> estimate ready (the oracle: its frame's ready time plus
      its declared latency);
    * ``servo_pickup``: estimate ready -> the first servo tick whose command used it;
    * ``end_to_end``: photon time -> that servo tick, where the joint targets that used the
      frame are written (``end_to_end_max``: the longest). The stages add up to it.
    """
    rec = stage.rec

    def ages(arrivals) -> list[np.ndarray]:
        return [np.array(a.t_ready) - np.array(a.t) for a in arrivals.values() if a.t]

    def ms(chunks, fn=np.mean) -> float | None:  # to the ns: tick times carry rounding
        return round(_mm(float(fn(np.concatenate(chunks)))), 6) if chunks else None

    # (photon, ready, servo tick) rows
    use = [np.array(v).reshape(-1, 3) for v in rec.first_use.values() if v]
    perception, estimate = ms(ages(rec.measurements)), ms(ages(rec.estimates))
    return {"perception": perception,
            "filter": None if perception is None or estimate is None else estimate - perception,
            "estimate": estimate, "servo_pickup": ms([u[:, 2] - u[:, 1] for u in use]),
            "end_to_end": ms([u[:, 2] - u[:, 0] for u in use]),
            "end_to_end_max": ms([u[:, 2] - u[:, 0] for u in use], np.max)}


def lag_metrics(sites: dict, lags: dict) -> dict:
    """Cross-correlation lags (ms) behind the mapped truth, means over the driven sites: of the
    commands (``interpolation``), of the IK's solution (``ik``) and of the robot
    (``end_to_end``). Lags, not delays: the hold PD lags by about half a frame more than the
    latency, extrapolation cancels the latency (a lag near 0 or negative)."""
    def mean_of(values):
        return float(np.mean(v)) if (v := [x for x in values if x is not None]) else None

    return {"interpolation": mean_of([v.get("interpolation") for v in lags.values()]),
            "ik": mean_of([v.get("ik") for v in lags.values()]),
            "end_to_end": mean_of([v.get("lag_ms") for v in sites.values()])}


def _joints_and_head(stage) -> tuple[dict, float, float]:
    """``(joints section, head displacement (m), head rotation (rad))`` from the record's
    per-tick joint and head columns, a block of rows at a time (a long run's columns are not
    gathered whole: ten minutes of 30 joints at 420 Hz are 60 MB a column)."""
    rec, n, rng = stage.rec, stage.rec.n, stage.scene.robot_range
    hits, worst, finite, dp, dr = 0, 0.0, True, 0.0, 0.0
    p0, R0 = (rec.p_head[0], rec.R_head[0]) if n else (None, None)
    for q, ctrl, p, R in zip(*(row_blocks(a, 0, n) for a in (rec.q_robot, rec.ctrl, rec.p_head,
                                                             rec.R_head)), strict=True):
        excess = np.maximum(rng[:, 0] - q, q - rng[:, 1])
        hits += int(np.sum(excess > 0.0))
        worst = max(worst, float(excess.max()))
        finite &= bool(np.all(np.isfinite(q)) and np.all(np.isfinite(ctrl)))
        d = head_motion(np.vstack([p0, p]), np.vstack([R0[None], R]).reshape(-1, 3, 3))
        dp, dr = max(dp, d[0]), max(dr, d[1])
    return ({"limit_violations": hits, "max_limit_excess_rad": worst, "finite": finite},
            dp, dr)


def mimic_metrics(stage) -> dict:
    rec, cfg = stage.rec, stage.cfg
    n = rec.n
    sites, lags = {}, {}
    for i, ch in enumerate(stage.channels):
        lags[ch.site], sites[ch.site] = site_metrics(stage, i, ch)
    latency, lag = latency_metrics(stage), lag_metrics(sites, lags)
    joints, dp, dr = _joints_and_head(stage)
    ik_ms = 1e3 * rec.ik_s[:n]
    out = {
        **sites, "mode": cfg.mode, "scale_setting": cfg.scale, "fit": cfg.fit.enabled,
        "perception": cfg.perception, "interpolation_mode": cfg.interpolation.mode,
        "head_still": {"max_displacement_mm": 1e3 * dp, "max_rotation_deg": float(np.degrees(dr))},
        "joints": joints,
        "ik": {"solve_ms_mean": float(ik_ms.mean()) if n else None,
               "solve_ms_p99": float(np.percentile(ik_ms, 99)) if n else None,
               "failures": int(stage.ik.failures), "ticks": int(n)},
    }
    gaze = gaze_metrics(stage)
    if gaze is not None:
        out["gaze"] = gaze
    return {"mimicry": out, "latency_ms": latency, "lag_ms": lag}
