"""Verdicts of a run from its ``metrics.json``: what went well and what did not, each with
the stated rule it comes from (:data:`THRESHOLDS`: the accuracy goals of the issues, guides for
a glance, not tests). Pure functions of the metrics; the page draws them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.metrics.mimicry import LOST_OFTEN
from humimic.world.person_view import MIN_FRONT_DISTANCE_M, OUT_OF_VIEW

#: (ok, warn, higher_is_better) per verdict: ok at or past the first value, warn up to the
#: second, bad beyond.
THRESHOLDS = {
    "detection_rate": (0.98, 0.90, True),
    "rmse_mm": (25.0, 50.0, False),
    "nees_in_band": (0.80, 0.50, True),
    "mimic_rmse_mm": (25.0, 50.0, False),
    "lag_ms": (50.0, 100.0, False),
    "mimic_lost_fraction": (0.05, LOST_OFTEN, False),
    "latency_ms": (50.0, 100.0, False),
    "slam_ate_m": (0.03, 0.10, False),
    "slam_heading_deg": (2.0, 5.0, False),
}
STATUS_COLOUR = {"ok": "#2e7d32", "warn": "#f9a825", "bad": "#c62828", "info": "#546e7a"}


@dataclass
class Verdict:
    label: str
    value: str
    status: str  # ok | warn | bad | info
    threshold: str = ""
    """The rule the status comes from, shown beside the value."""


# ---- rules ---------------------------------------------------------------------------------
def grade(kind: str, value: float | None) -> tuple[str, str]:
    """``(status, rule)`` of ``value`` under :data:`THRESHOLDS` ``[kind]``."""
    ok, warn, higher = THRESHOLDS[kind]
    cmp = "≥" if higher else "≤"
    rule = f"ok {cmp} {ok:g}, warn {cmp} {warn:g}"
    if value is None:
        return "bad", rule
    if higher:
        return ("ok" if value >= ok else "warn" if value >= warn else "bad"), rule
    return ("ok" if value <= ok else "warn" if value <= warn else "bad"), rule


def _worst(*statuses: str) -> str:
    return max(statuses, key=["info", "ok", "warn", "bad"].index)


def _tracking_verdicts(target: str, s: dict) -> list[Verdict]:
    if s.get("verdict") == "unscored":  # the run ended while detection was still blind
        return [Verdict(f"{target}: detection rate", f"not scored ({s.get('cause')})", "info",
                        "")]
    rate = s.get("detection_rate")
    never = rate is None or s.get("time_to_first_detection_s") is None
    value = "never detected" if never else f"{rate:.3f}"
    if s.get("verdict") == "poor":  # against the visibility ground truth
        value += (f" of its visible frames (visible {s.get('visible_fraction', 0.0):.0%}; "
                  f"likely cause: {s.get('cause')})")
    out = [Verdict(f"{target}: detection rate", value,
                   *grade("detection_rate", None if never else rate))]
    f, raw = s.get("filtered_rmse_mm"), s.get("raw_rmse_mm")
    if f is None and raw is None:
        return out
    status, rule = grade("rmse_mm", f if f is not None else raw)
    value = (f"filtered {f:.1f} mm" if f is not None else "no filter") + (
        f", raw {raw:.1f} mm" if raw is not None else "")
    if f is not None and raw is not None and f >= raw:
        status, value = _worst(status, "warn"), value + ": the filter does not improve on raw"
    out.append(Verdict(f"{target}: 3-D RMSE", value, status, rule))
    if s.get("biased"):
        bias = np.linalg.norm([b or 0.0 for b in s.get("raw_bias_mm") or [0.0]])
        share = s.get("raw_bias_share") or 0.0
        out.append(Verdict(
            f"{target}: biased", f"mean error {bias:.1f} mm, {100 * share:.0f} % of the mean "
            "square (stereo sees the surface, the truth is the part's centre)", "warn",
            "bias share ≤ 50 %"))
    band = s.get("filtered_nees_pos3_in_band")
    if band is not None:
        raw_d = s.get("raw_nees_pos3_debiased_in_band")
        extra = f"; raw, bias removed: {100 * raw_d:.0f} %" if raw_d is not None else ""
        out.append(Verdict(f"{target}: filter consistency",
                           f"{100 * band:.0f} % of frames inside the 95 % χ² band of position "
                           f"NEES (3 dof){extra}", *grade("nees_in_band", band)))
    return out


def verdicts(metrics: dict) -> list[Verdict]:
    """What went well and what did not, from ``metrics.json``, each with its rule."""
    out = [Verdict("run", f"{metrics.get('sim_time_s', 0):.2f} s simulated, "
                          f"{metrics.get('realtime_factor', 0):.2f}x real time",
                   "bad" if metrics.get("interrupted") else "info",
                   "interrupted" if metrics.get("interrupted") else "")]
    warnings = metrics.get("mujoco_warnings") or {}
    out.append(Verdict("MuJoCo warnings", ", ".join(f"{k}: {v}" for k, v in warnings.items())
                       or "none", "bad" if warnings else "ok", "none"))
    out.extend(_person_view_verdicts(metrics.get("person_view")))
    for target, s in (metrics.get("tracking") or {}).items():
        out.extend(_tracking_verdicts(target, s))
    for site, s in (metrics.get("mimicry") or {}).items():
        if isinstance(s, dict) and "rmse_mm" in s:
            out.append(_mimicry_verdict(site, s))
    joints = (metrics.get("mimicry") or {}).get("joints")
    if joints:
        bad = joints.get("limit_violations", 0) or not joints.get("finite", True)
        out.append(Verdict("robot joints", "NaN!" if not joints.get("finite", True) else
                           f"{joints.get('limit_violations', 0)} limit violations",
                           "bad" if bad else "ok", "none"))
    e2e = (metrics.get("latency_ms") or {}).get("end_to_end")
    if e2e is not None:
        out.append(Verdict("latency, photon to joint command", f"{e2e:.1f} ms",
                           *grade("latency_ms", e2e)))
    out.extend(_slam_verdicts(metrics.get("slam")))
    for name, s in (metrics.get("trackers") or {}).items():
        out.extend(_tracker_verdicts(name, s))
    return out


def _person_view_verdicts(view: dict | None) -> list[Verdict]:
    """A warning line when the scripted person leaves the eyes' start view or comes too near
    (``person_view``; the full sentence is in the run's warning line); none otherwise."""
    if not view or not view.get("warning"):
        return []
    out, first = view.get("out_of_view_fraction") or 0.0, view.get("first_out_of_view_s")
    d, when = view.get("min_front_distance_m"), view.get("min_front_distance_t_s")
    value = f"out of the eyes' start view on {out:.0%} of the run" + (
        f" (from {first:.1f} s)" if first is not None else "")
    if d is not None and d < MIN_FRONT_DISTANCE_M:
        value += (f"; {-d:.2f} m behind the eyes at {when:.1f} s: walks through the robot"
                  if d < 0 else f"; {d:.2f} m in front of the eyes at {when:.1f} s")
    return [Verdict("person in view", value, "warn", f"out of view ≤ {OUT_OF_VIEW:.0%}, "
                    f"≥ {MIN_FRONT_DISTANCE_M:g} m in front")]


def _mimicry_verdict(site: str, s: dict) -> Verdict:
    """A driven site's RMSE and lag, and the share of the run its target was lost (a stale
    target held: ``lost_often`` beyond the warn bound); an unscored site's reason."""
    if s.get("rmse_mm") is None:
        return Verdict(f"mimicry {site}", s.get("reason", s.get("status", "")), "bad")
    (st_r, rule_r), (st_l, rule_l) = (grade("mimic_rmse_mm", s["rmse_mm"]),
                                      grade("lag_ms", abs(s.get("lag_ms") or 0.0)))
    value = f"{s['rmse_mm']:.1f} mm / {s.get('lag_ms', float('nan')):.0f} ms"
    status, rule = _worst(st_r, st_l), f"RMSE {rule_r}; |lag| {rule_l}"
    lost = s.get("lost_fraction") or 0.0
    if lost > 0.0:  # the scores hold over the ticks a stale target was held too
        st_lost, rule_lost = grade("mimic_lost_fraction", lost)
        value += f"; {s.get('target', 'target')} lost on {lost:.0%} of the ticks (held stale)"
        status, rule = _worst(status, st_lost), f"{rule}; lost {rule_lost}"
    return Verdict(f"mimicry {site}: RMSE / lag", value, status, rule)


#: A tracker's headline errors, whichever it reports (``trackers.<name>.*``), and their units.
TRACKER_ERRORS = (("center_rmse_px", "px centre RMSE"), ("position_rmse_mm", "mm position RMSE"),
                  ("wrist_rmse_mm", "mm wrist RMSE"), ("wrist_error_mm", "mm mean wrist error"),
                  ("joint_rmse_deg", "° joint RMSE"))


def _tracker_verdicts(name: str, s: dict) -> list[Verdict]:
    """One line per tracker: its headline errors and lost share (no threshold: a researcher's
    comparison, shown as info), a warning when it followed someone else."""
    if not isinstance(s, dict) or not s.get("frames"):
        return []
    parts = [f"{s[k]:.1f} {unit}" for k, unit in TRACKER_ERRORS if s.get(k) is not None]
    lost, visible = s.get("lost_fraction"), s.get("visible_frames")
    if lost is not None:  # of the visible frames where the tracker knows them
        parts.append(f"lost on {lost:.0%} of {visible} visible frames" if visible is not None
                     else f"lost fraction {lost:.0%}")
    switches = s.get("identity_switches") or 0
    if switches:
        parts.append(f"{switches} identity switches")
    return [Verdict(f"tracker {name}", "; ".join(parts) or "no scores",
                    "warn" if switches else "info", "identity switches: none" if switches
                    else "")]


def _slam_verdicts(s: dict | None) -> list[Verdict]:
    if not s or not s.get("frames"):
        return []
    ate, head = s.get("ate_rmse_m"), s.get("heading_rmse_deg")
    (st_a, rule_a), (st_h, rule_h) = grade("slam_ate_m", ate), grade("slam_heading_deg", head)
    out = [Verdict(f"SLAM ({s.get('mode')}): head position / heading RMSE",
                   f"{100 * ate:.1f} cm / {head:.2f} deg" if ate is not None and head is not None
                   else "no estimate", _worst(st_a, st_h),
                   f"position {rule_a} m; heading {rule_h} deg")]
    if s.get("mode") != "inertial":
        lost = s.get("frames_without_features", 0)
        out.append(Verdict("SLAM: features measured per frame",
                           f"{s.get('features_per_frame', 0):.1f}; {lost} frames without one",
                           "ok" if lost == 0 else "warn", "every frame measures one"))
    return out
