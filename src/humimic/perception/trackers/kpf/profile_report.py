"""``schmidt-depth-profile``'s summary, plot and command line (see
:mod:`~humimic.perception.trackers.kpf.profile_run`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from humimic.errors import report_error
from humimic.paths import SCENARIOS_DIR
from humimic.perception.trackers.kpf.profile import within
from humimic.perception.trackers.kpf.profile_run import (
    NATS,
    PHASES,
    disparity_change,
    profile_run,
)
from humimic.perception.trackers.kpf.table1 import EYES, seed_list
from humimic.scenario.errors import ScenarioError

#: Issue 14's goals: mean wrist error (mm) at 1000 particles.
GOALS_MM = {"side": 40.0, "angle": 60.0}
#: A mirror whose wrist lies this far (m) from the truth's counts as a distinct pose.
DISTINCT_M = 0.05


def rescaled(rows: list[dict], delta: np.ndarray, k: float) -> list[dict]:
    """``rows`` with every log-likelihood difference scaled by ``k`` (the cue sigmas divided
    by ``sqrt(k)``: the same information trusted ``k`` times more) and the intervals
    recomputed; the maxima do not move."""
    out = []
    for r in rows:
        r = {**r, "log_lik": (k * np.array(r["log_lik"], float)).tolist(),
             "flip_rel": {f: k * v for f, v in r["flip_rel"].items()}}
        for n in NATS:
            lo, hi, cens = within(delta, np.array(r["log_lik"]), 0.0, n)
            r[f"within_{n:g}"] = [lo, hi, cens]
        out.append(r)
    return out


def ambiguity(row: dict, nats: float) -> float:
    """How far (m) from the true wrist the wrist of a pose scoring at least the truth's
    log-likelihood minus ``nats`` lies, the farthest among the ray's interval and the mirrors
    (a frame of :class:`ProfileProbe`)."""
    lo, hi, _ = row[f"within_{nats:g}"]
    far = [-lo, hi] + [row["flip_wrist_m"][k] for k, v in row["flip_rel"].items()
                       if v is not None and np.isfinite(v) and v >= -nats]
    return float(max(far))


def posterior_error(row: dict) -> float:
    """The mean wrist error (m, to the true wrist) under the likelihood over the ray's offsets
    and the mirrors, ``exp(log p)`` normalised, each mirror weighing as one offset (a uniform
    prior over the grid: what a particle set sampling these poses would average to)."""
    ll = np.array(row["log_lik"] + [row["flip_rel"][k] for k in row["flip_rel"]], float)
    err = np.concatenate([row["ray_error_m"], [row["flip_error_m"][k] for k in row["flip_rel"]]])
    ok = np.isfinite(ll) & np.isfinite(err)
    w = np.exp(ll[ok] - ll[ok].max())
    return float(w @ err[ok] / w.sum())


def posterior_ray_offset(row: dict, delta: np.ndarray) -> float:
    """The mean offset (m, signed) along the ray under the likelihood over the ray's offsets
    (uniform prior over the grid): a weighted-average estimator's depth error."""
    ll = np.array(row["log_lik"], float)
    ok = np.isfinite(ll)
    w = np.exp(ll[ok] - ll[ok].max())
    return float(w @ delta[ok] / w.sum())


def mirror_margin(row: dict, min_m: float = DISTINCT_M) -> float:
    """The truth's log-likelihood minus the best mirror's among those whose wrist lies at
    least ``min_m`` from the true one (nats; NaN without one)."""
    v = [r for k, r in row["flip_rel"].items()
         if np.isfinite(r) and row["flip_wrist_m"][k] >= min_m]
    return -max(v) if v else float("nan")


def summarise(rows: list[dict], delta: np.ndarray) -> dict:
    """Means (and medians) over ``rows`` (frames of :class:`ProfileProbe`): interval widths
    (mm) and their censored share, :func:`ambiguity` (mm), the ray maximum's offset (mm), the
    maximum-likelihood choice's wrist error (mm), :func:`posterior_error` and
    :func:`posterior_ray_offset` (mm), the distinct mirrors' margin (:func:`mirror_margin`,
    nats) and the share of frames it is under 0.5 nats."""
    if not rows:
        return {"frames": 0}
    mm = 1e3
    out = {"frames": len(rows)}
    for n in NATS:
        w = np.array([r[f"within_{n:g}"] for r in rows], float)
        width = mm * (w[:, 1] - w[:, 0])
        out[f"width_{n:g}_mean_mm"] = float(width.mean())
        out[f"width_{n:g}_median_mm"] = float(np.median(width))
        out[f"width_{n:g}_censored"] = float(w[:, 2].mean())
        out[f"near_{n:g}_mean_mm"] = float(-mm * w[:, 0].mean())
        out[f"ambiguity_{n:g}_mean_mm"] = float(mm * np.mean([ambiguity(r, n) for r in rows]))
    off = mm * np.array([r["ray_offset_m"] for r in rows])
    out["ray_ml_abs_mean_mm"] = float(np.abs(off).mean())
    out["ray_ml_mean_mm"] = float(off.mean())
    out["ml_error_mean_mm"] = float(mm * np.mean([r["ml_error_m"] for r in rows]))
    out["ml_mirror_share"] = float(np.mean([r["ml"] != "ray" for r in rows]))
    out["posterior_error_mean_mm"] = float(mm * np.mean([posterior_error(r)
                                                         for r in rows]))
    po = mm * np.array([posterior_ray_offset(r, delta) for r in rows])
    out["posterior_ray_offset_mean_mm"] = float(po.mean())
    out["posterior_ray_offset_abs_mean_mm"] = float(np.abs(po).mean())
    m = np.array([mirror_margin(r) for r in rows], float)
    out["mirror_frames"] = int(np.isfinite(m).sum())
    m = m[np.isfinite(m)]
    out["mirror_margin_median"] = float(np.median(m)) if len(m) else None
    out["mirror_close_share"] = float(np.mean(m < 0.5)) if len(m) else None
    out["range_mean_m"] = float(np.mean([r["range_m"] for r in rows]))
    return out


def table(results: dict) -> str:
    """One line per gesture and phase (and all frames) of :func:`summarise`."""
    head = (f"{'gesture':>7} {'phase':>6} {'n':>4} {'0.5-nat mm':>16} {'2-nat mm':>16} "
            f"{'near 0.5/2':>11} {'amb 0.5/2':>11} {'|ML ray| mm':>12} {'ML err mm':>10} "
            f"{'post err':>9} {'mirror':>19}")
    lines = ["interval widths: mean / median (censored share); near: how far towards the "
             "camera they reach (mean, mm); amb: the farthest wrist (mm) of a pose within 0.5 / "
             "2 nats of the truth, on the ray or a mirror (mean); ML ray: |offset| of the "
             "profile's maximum, mean "
             "(signed mean); ML err: the wrist error of the best among the ray's poses and the "
             "mirrors (mean); post err: the mean wrist error under the likelihood over those "
             "poses (mean); mirror: median margin truth - best mirror >= 50 mm away (nats) / "
             "share of frames under 0.5 nats (frames with such a mirror)", head]
    for gesture, by in results.items():
        for ph in (*PHASES, "all"):
            s = by.get(ph)
            if not s or not s["frames"]:
                continue
            mirror = ("--" if s["mirror_margin_median"] is None else
                      f"{s['mirror_margin_median']:5.2f} / {s['mirror_close_share']:4.2f} "
                      f"({s['mirror_frames']})")
            lines.append(
                f"{gesture:>7} {ph:>6} {s['frames']:>4} "
                + " ".join(f"{s[f'width_{n:g}_mean_mm']:5.0f}/{s[f'width_{n:g}_median_mm']:4.0f}"
                           f" ({s[f'width_{n:g}_censored']:4.2f})" for n in NATS)
                + f" {s['near_0.5_mean_mm']:5.0f}/{s['near_2_mean_mm']:4.0f}"
                + f" {s['ambiguity_0.5_mean_mm']:5.0f}/{s['ambiguity_2_mean_mm']:4.0f}"
                + f" {s['ray_ml_abs_mean_mm']:4.0f} ({s['ray_ml_mean_mm']:+4.0f})"
                + f" {s['ml_error_mean_mm']:10.0f} {s['posterior_error_mean_mm']:9.0f}"
                + f" {mirror:>19}")
    return "\n".join(lines)


def plot(results_rows: dict, delta: np.ndarray, path: Path) -> Path:
    """The mean (and 25-75 % band) of ``log p(pose moved delta) - log p(truth)`` per gesture
    and phase (rise, hold)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results_rows), figsize=(5.5 * len(results_rows), 4),
                             squeeze=False, sharey=True)
    for ax, (gesture, rows) in zip(axes[0], results_rows.items(), strict=True):
        for ph, colour in (("rise", "tab:orange"), ("hold", "tab:blue"), ("rest", "tab:gray")):
            ll = np.array([r["log_lik"] for r in rows if r["phase"] == ph], float)
            if not len(ll):
                continue
            with np.errstate(all="ignore"):
                import warnings

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    mean = np.nanmean(ll, axis=0)
                    lo, hi = np.nanpercentile(ll, [25, 75], axis=0)
            ax.plot(1e3 * delta, mean, color=colour, label=f"{ph} ({len(ll)} frames)")
            ax.fill_between(1e3 * delta, lo, hi, color=colour, alpha=0.2)
        for n in NATS:
            ax.axhline(-n, color="k", lw=0.6, ls=":")
        ax.axvline(0.0, color="k", lw=0.6)
        ax.set_title(f"{gesture} pointing")
        ax.set_xlabel("wrist moved along its camera ray (mm, + away)")
        ax.legend(fontsize=8)
    axes[0, 0].set_ylabel("log-likelihood - truth's (nats)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def render_profiles(args, delta: np.ndarray) -> tuple[dict, dict]:
    """Every gesture and seed of ``args`` rendered and profiled: ``({gesture: rows}, info)``."""
    from humimic.scenario import load_scenario

    rows_by: dict[str, list] = {}
    info: dict = {}
    for gesture in args.gesture:
        for seed in args.seeds:
            sc = load_scenario(SCENARIOS_DIR / EYES[args.eye],
                               [*args.set, f"human.motion.gestures=[{gesture}]"],
                               seed=seed, **({} if args.duration is None
                                             else {"duration": args.duration}))
            if args.tracker not in (sc.trackers or {}):
                raise ScenarioError(sc.name, "--tracker", "no such tracker", args.tracker,
                                    ", ".join(sc.trackers or {}))
            rows, info = profile_run(sc, args.tracker, delta,
                                     1e-3 * np.asarray(args.torso_offset), args.gaze)
            for r in rows:
                r["seed"] = seed
            rows_by.setdefault(gesture, []).extend(rows)
            print(f"{gesture} seed {seed}: {len(rows)} frames", flush=True)
    info.update(eye=sc.cameras.which, resolution=list(sc.cameras.resolution),
                distance_m=sc.human.distance, tracker=args.tracker, seeds=args.seeds,
                torso_offset_mm=list(args.torso_offset), gaze=args.gaze)
    return rows_by, info


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m humimic.perception.reproduce "
                                "schmidt-depth-profile",
                                description="the tracker likelihood's profile along the true "
                                "wrist's depth on Table 1's frames (issue 14)")
    p.add_argument("--gesture", nargs="+", choices=sorted(GOALS_MM), default=["side", "angle"])
    p.add_argument("--eye", choices=sorted(EYES), default="wide")
    p.add_argument("--seeds", type=int, nargs="+", default=[5],
                   help="N: seeds 0..N-1 (default: 5); several: these seeds (as schmidt-table1)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="scenario override (repeatable), e.g. cameras.resolution=[640,480]")
    p.add_argument("--tracker", default="kpf", help="whose likelihood (default kpf)")
    p.add_argument("--range", type=float, default=200.0, help="offsets +- this (mm)")
    p.add_argument("--step", type=float, default=10.0, help="offset step (mm)")
    p.add_argument("--duration", type=float, default=None, help="simulated s per run")
    p.add_argument("--torso-offset", type=float, nargs=3, default=(0.0, 0.0, 0.0),
                   metavar=("X", "Y", "Z"), help="profile around the true pose with its torso "
                   "moved by this (mm, robot base frame: x towards the person)")
    p.add_argument("--gaze", nargs="+", default=None, metavar="TARGET",
                   choices=["right_elbow", "right_wrist", "right_hand", "right_shoulder"],
                   help="turn the eyes every servo tick to the mean of these TRUE human "
                   "targets (foveated active gaze on the arm; e.g. right_elbow right_wrist)")
    p.add_argument("--out", type=Path, default=None, help="directory for JSON and PNG")
    p.add_argument("--from", dest="source", type=Path, default=None,
                   help="summarise this --out directory's profile.json instead of rendering")
    p.add_argument("--scale", type=float, default=1.0,
                   help="summarise the log-likelihoods times this (the cue sigmas divided by "
                   "its square root; default 1)")
    args = p.parse_args(argv)
    try:
        args.seeds = seed_list(args.seeds)
        for name in ("step", "range", "scale"):
            if not getattr(args, name) > 0.0:
                raise ValueError(f"--{name} {getattr(args, name):g}: must be > 0")
    except ValueError as err:
        print(f"schmidt-depth-profile: {err}", file=sys.stderr)
        return 2
    if args.source is not None:
        d = json.loads((args.source / "profile.json").read_text())
        delta, info, rows_by = np.array(d["delta_m"]), d["info"], d["frames"]
    else:
        k = int(round(args.range / args.step))
        delta = 1e-3 * args.step * np.arange(-k, k + 1)
        try:
            rows_by, info = render_profiles(args, delta)
        except ScenarioError as err:
            return report_error(err)
    if args.scale != 1.0:
        rows_by = {g: rescaled(rows, delta, args.scale) for g, rows in rows_by.items()}
        print(f"log-likelihoods scaled by {args.scale:g}")
    results = {g: {**{ph: summarise([r for r in rows if r["phase"] == ph], delta)
                      for ph in PHASES}, "all": summarise(rows, delta)}
               for g, rows in rows_by.items()}
    print(f"\n{info['eye']} eye, {info['resolution'][0]} x {info['resolution'][1]}"
          f" (f = {info['fx_px']:.1f} px), person {info['distance_m']:g} m away; likelihood of "
          f"trackers.{info['tracker']}; seeds {info['seeds']}; torso moved "
          f"{info.get('torso_offset_mm', [0, 0, 0])} mm; gaze on {info.get('gaze') or '-'}")
    print(table(results))
    for g, by in results.items():
        a = by["all"]
        print(f"{g}: an ML estimator over the ray and mirrors errs {a['ml_error_mean_mm']:.0f} "
              f"mm on average (goal {GOALS_MM[g]:g} mm), the likelihood's mean over them "
              f"{a['posterior_error_mean_mm']:.0f} mm (along the ray alone: |mean offset| "
              f"{a['posterior_ray_offset_abs_mean_mm']:.0f} mm, signed "
              f"{a['posterior_ray_offset_mean_mm']:+.0f}); poses within 0.5 nats of the truth "
              f"reach {a['ambiguity_0.5_mean_mm']:.0f} mm from it")
    b, f, z = info["baseline_m"], info["fx_px"], info["distance_m"]
    print(f"stereo: baseline {1e3 * b:.1f} mm (robot model); disparity at {z:g} m "
          f"{f * b / z:.2f} px; a 20 mm depth change moves it "
          f"{disparity_change(f, b, z, 0.02):.3f} px (f = {f:.1f} px)")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "profile.json").write_text(json.dumps(
            {"delta_m": delta.tolist(), "info": info, "summary": results, "frames": rows_by},
            allow_nan=True))
        print("plot:", plot(rows_by, delta, args.out / "depth_profile.png"))
    return 0
