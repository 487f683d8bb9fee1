"""The summary table printed at the end of a run (rich)."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.table import Table

from humimic.metrics.flatten import flatten_metrics
from humimic.metrics.mimicry_report import STILL_TARGET_MM

#: Score sections of ``metrics.json`` (shared/design.md's namespaces) and how many keys deep
#: the table goes: ``trackers.<name>.recognition.<count>`` is four.
SECTIONS = {"tracking": 3, "trackers": 4, "slam": 3, "arm": 3, "commands": 3, "mimicry": 3,
            "latency_ms": 3, "lag_ms": 3}


#: A target whose raw 3-D measurements, their mean error removed, fall above the 95 % chi^2
#: band of the covariance R perception reported on more of its frames than this (0.025 when
#: consistent) is named in the run's warning (:func:`inconsistent_measurements`). Measured
#: (fraction above): the default ude_wave_tracking (seed 3) 0-0.022, mimic_tracked_wave (seed
#: 7) 0.012-0.026, ude_table3_static_hand 0.038; a shirt of nearly the skin's colour ([0.76,
#: 0.60, 0.45], ude_wave_tracking seed 3) 0.53-0.57 (0.38-0.46 with the closed colour mask),
#: whose filtered RMSE doubled with no warning.
CONSISTENT_ABOVE_BAND = 0.2
#: ... over at least this many measured frames.
CONSISTENT_MIN_FRAMES = 30


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if value is None:
        return "-"
    return str(value)


def summary_rows(metrics: dict) -> list[tuple[str, str]]:
    """(key, value) rows: run facts, then stage costs, then each score section."""
    rows = [(k, _fmt(metrics[k])) for k in ("scenario", "seed", "sim_time_s", "wall_time_s",
                                            "realtime_factor", "interrupted") if k in metrics]
    for name, st in metrics.get("stages", {}).items():
        rows.append((f"stages.{name}", f"{st['mean_ms']:.3f} ms x {st['calls']}"))
    for section, depth in SECTIONS.items():
        flat = flatten_metrics({section: metrics.get(section, {})}, max_depth=depth, lists=False)
        rows.extend((key, _fmt(value)) for key, value in flat.items())
    if metrics.get("mujoco_warnings"):
        rows.append(("mujoco_warnings", _fmt(metrics["mujoco_warnings"])))
    return rows


def print_summary(metrics: dict, out_dir: str | Path, console: Console | None = None) -> None:
    console = console or Console()
    table = Table(title=f"humimic run: {metrics.get('scenario')}", show_header=True)
    table.add_column("metric", style="cyan")
    table.add_column("value", justify="right")
    for key, value in summary_rows(metrics):
        poor = key.endswith(".verdict") and value == "poor"
        table.add_row(key, value, style="bold red" if poor else None)
    console.print(table)
    console.print(f"outputs in [bold]{out_dir}[/bold]  (open the recording: rerun "
                  f"{Path(out_dir) / 'run.rrd'})")


def inconsistent_measurements(target: str, s: dict) -> str | None:
    """A warning clause for a ``tracking.<target>`` section whose measurements scatter beyond
    their reported covariance R (``raw_nees_pos3_debiased_above_band`` over
    :data:`CONSISTENT_ABOVE_BAND`, on at least :data:`CONSISTENT_MIN_FRAMES` measured frames):
    its errors are larger than perception believes and the filter is over-confident; else
    None."""
    above = s.get("raw_nees_pos3_debiased_above_band")
    if above is None or (s.get("measured_frames") or 0) < CONSISTENT_MIN_FRAMES \
            or above <= CONSISTENT_ABOVE_BAND:
        return None
    filt = s.get("filtered_nees_pos3_in_band")
    also = "" if filt is None else f"; filtered NEES in the band on {filt:.0%}"
    return (f"{target}'s 3-D measurements scatter beyond the covariance perception reports "
            f"(debiased NEES above the 95 % band on {above:.0%} of frames{also})")


def verdict_warning(metrics: dict) -> str | None:
    """One line naming every target detected on less than half of its visible frames, or
    never, with its likely cause (``tracking.<target>.verdict``), and the perception stage's
    ``colour_warning`` and each tracker's (``trackers.<name>.colour_warning``) when they have
    one (a scene with look-alikes of the skin's colours), each target whose measurements are
    inconsistent with their covariance (:func:`inconsistent_measurements`), the scripted
    person leaving the eyes' view or walking through the robot (``person_view.warning``), and
    each mimicry site whose target was lost much of the run (``status: lost_often``) or whose
    human part hardly moved (``mimicry.<site>.mapped_motion_rms_mm``); None when there is
    none."""
    poor = []
    for target, s in metrics.get("tracking", {}).items():
        if isinstance(s, dict) and s.get("verdict") == "poor":
            rate = s.get("detection_rate")
            seen = ("never visible" if rate is None else "never detected" if rate == 0.0
                    else f"detected on {rate:.0%} of visible frames")
            poor.append(f"{target} {seen} (likely cause: {s.get('cause')})")
        elif isinstance(s, dict) and s.get("verdict") == "unscored":
            poor.append(f"{target} not scored ({s.get('cause')})")
        if isinstance(s, dict) and s.get("verdict") != "poor":
            clause = inconsistent_measurements(target, s)
            if clause:
                poor.append(clause)
    colour = metrics.get("perception", {}).get("colour_warning")
    if colour:
        poor.append(colour)
    for name, s in metrics.get("trackers", {}).items():  # each tracker's own skin model
        if isinstance(s, dict) and s.get("colour_warning"):
            poor.append(f"{name}'s skin model: {s['colour_warning']}")
    view = (metrics.get("person_view") or {}).get("warning")
    if view:  # the scripted person leaves the eyes' view or walks through the robot
        poor.append(view)
    for site, s in metrics.get("mimicry", {}).items():  # a mapping with nothing to copy
        if isinstance(s, dict) and s.get("status") == "lost_often":
            poor.append(f"mimicry.{site}: {s.get('reason')}")
        moved = s.get("mapped_motion_rms_mm") if isinstance(s, dict) else None
        if moved is not None and moved < STILL_TARGET_MM:
            poor.append(f"mimicry.{site}: its human part {s.get('target')} hardly moved "
                        f"({moved:.1f} mm RMS, mapped): nothing to copy (is mimic.map on the "
                        f"moving part?)")
    return f"warning: {'; '.join(poor)}" if poor else None
