"""Reproduce Schmidt, Fritsch & Kwolek's Table 1 (mean wrist error over runs, by particles and
mean-shift iterations, side and angular pointing) and print it beside the paper's.

``python -m humimic.perception.reproduce schmidt-table1 [--eye wide|foveal] [--out DIR] [--jobs N]
[--seeds N | S S ...] [--duration S] [--particles N ...] [--set KEY=VALUE ...] [--no-run]`` runs
``sweeps/schmidt_table1.yaml`` (``--eye foveal``: on ``scenarios/schmidt_table1_foveal.yaml``,
the left eye's 24 deg camera with the person at 4.4 m, instead of the wide eye at 2 m; the
rows of those particle counts, default all; ``--seeds``: N
seeds 0..N-1, or the seeds listed; ``--set``: scenario overrides for every run, e.g. a
sensitivity study at another distance) through the sweep tool (complete runs are skipped),
then reads every run's ``metrics.json``. Each run holds three trackers on the same frames
(``scenarios/schmidt_table1.yaml``): ``kpf`` (ours: partitioned mean shift, torso prior),
``kpf_paper`` (the published method) and ``condensation``. Per run the error is the mean over
frames of the distance between the true wrist and the model's forearm end; the table gives its
mean and standard deviation over the seeds (the paper's "Var." column is read as the spread
over its 5 runs, in mm), the error split into its image-plane and depth components (across
and along the camera ray through the true wrist) and the flip-free error (to the nearest of
the estimate's kinematic flips: what the monocular depth ambiguity does not explain).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from humimic.errors import report_error
from humimic.paths import SCENARIOS_DIR
from humimic.scenario.errors import ScenarioError
from humimic.scenario.load import parse_override

SWEEP = SCENARIOS_DIR.parent / "sweeps" / "schmidt_table1.yaml"
CONFIGS = ((1000, 3), (500, 3), (250, 3), (150, 2))
#: The paper's Table 1: (particles, iterations) -> (side mean, side var, angular mean, var), mm.
PAPER = {(1000, 3): (77.5, 42.1, 124.2, 46.5), (500, 3): (75.9, 46.7, 141.4, 60.8),
         (250, 3): (94.1, 55.7, 156.6, 77.1), (150, 2): (116.0, 70.6, 253.8, 216.0)}
TRACKERS = ("kpf", "kpf_paper", "condensation")
#: ``--eye`` -> the sweep's base scenario: one eye camera at 320 x 240 either way (issue 14).
EYES = {"wide": "schmidt_table1.yaml", "foveal": "schmidt_table1_foveal.yaml"}
KEYS = ("wrist_error_mm", "wrist_lateral_mm", "wrist_depth_mm", "wrist_flip_free_mm",
        "frames_per_s")


def seed_list(values: list[int]) -> list[int]:
    """``--seeds`` of the reproduction commands: one value N, seeds 0..N-1; several, these
    seeds. ``ValueError`` for a count below 1 (no runs)."""
    if len(values) > 1:
        return list(values)
    if values[0] < 1:
        raise ValueError(f"--seeds {values[0]}: no runs; give a count >= 1 (seeds 0..N-1) or "
                         "two or more seeds")
    return list(range(values[0]))


def _usage(message: str) -> int:
    """A bad argument: one line on stderr, exit code 2 (as a bad scenario)."""
    print(f"schmidt-table1: {message}", file=sys.stderr)
    return 2


def collect(planned) -> dict:
    """``{(gesture, particles, iterations, tracker): {key: [values over seeds]}}`` from the
    runs' ``metrics.json`` (runs without one are skipped)."""
    out: dict = {}
    for p in planned:
        f = p.out_dir / "metrics.json"
        if not f.is_file():
            continue
        m = json.loads(f.read_text())
        gesture = p.scenario.human.motion.gestures[0]
        for name in TRACKERS:
            cfg = p.scenario.trackers.get(name)
            t = m.get("trackers", {}).get(name)
            if cfg is None or t is None:
                continue
            iters = dict(CONFIGS).get(cfg.n_particles, cfg.iterations)  # CONDENSATION: none
            row = out.setdefault((gesture, cfg.n_particles, iters, name), {k: [] for k in KEYS})
            for k in KEYS:
                row[k].append(t[k])
    return out


def _ms(vals) -> str:
    if not vals:
        return "      --      "
    v = np.asarray(vals, float)
    return f"{v.mean():6.1f} ± {v.std(ddof=1) if len(v) > 1 else 0.0:5.1f}"


def table(results: dict) -> str:
    lines = []
    for gesture, col in (("side", 0), ("angle", 2)):
        lines.append(f"\n{gesture} pointing: wrist error mean ± sd over runs (mm); paper mean "
                     "(var); kpf's error across / along the camera ray and flip-free; frames/s")
        lines.append(f"{'(N, it)':>10} {'paper':>14} " + " ".join(f"{t:>16}" for t in TRACKERS)
                     + f" {'kpf lat/depth/flip':>20} {'fps kpf/paper/cond':>20}")
        for cfg in CONFIGS:
            pm, pv = PAPER[cfg][col], PAPER[cfg][col + 1]
            rows = [results.get((gesture, *cfg, t), {}) for t in TRACKERS]
            lat = rows[0].get("wrist_lateral_mm", [])
            dep = rows[0].get("wrist_depth_mm", [])
            flip = rows[0].get("wrist_flip_free_mm", [])
            split = (f"{np.mean(lat):4.0f} / {np.mean(dep):4.0f} / {np.mean(flip):4.0f}"
                     if lat and flip else "--")
            fps = "/".join(f"{np.mean(r['frames_per_s']):.1f}" if r else "--" for r in rows)
            lines.append(f"{str(cfg):>10} {pm:7.1f} ({pv:5.1f}) "
                         + " ".join(f"{_ms(r.get('wrist_error_mm', [])):>16}" for r in rows)
                         + f" {split:>20} {fps:>20}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    from humimic.sweep.config import load_sweep
    from humimic.sweep.driver import default_out_dir, run_sweep
    from humimic.sweep.plan import plan_sweep

    p = argparse.ArgumentParser(prog="python -m humimic.perception.reproduce schmidt-table1",
                                description=__doc__.split("\n")[0])
    p.add_argument("--eye", choices=sorted(EYES), default="wide",
                   help="wide: the 100 deg eye, the person at 2 m (default); foveal: the 24 deg "
                   "eye, the person at 4.4 m (scenarios/schmidt_table1_foveal.yaml)")
    p.add_argument("--out", type=Path, default=None, help="sweep directory")
    p.add_argument("--jobs", type=int, default=1, help="parallel runs (default 1)")
    p.add_argument("--seeds", type=int, nargs="+", default=None,
                   help="N: seeds 0..N-1 per point (default: 5); several: these seeds")
    p.add_argument("--duration", type=float, default=None, help="simulated s per run")
    p.add_argument("--no-run", action="store_true", help="only read finished runs")
    p.add_argument("--particles", type=int, nargs="+", default=None,
                   help="only these rows of Table 1 (by particles, e.g. 1000 150)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="scenario override for every run (repeatable), e.g. human.distance=3")
    args = p.parse_args(argv)
    if args.jobs < 1:
        return _usage(f"--jobs {args.jobs}: give 1 or more parallel runs")
    try:
        seeds = None if args.seeds is None else seed_list(args.seeds)
    except ValueError as err:
        return _usage(str(err))
    rows = sorted({n for n, _ in CONFIGS})
    if args.particles is not None and not set(args.particles) <= set(rows):
        return _usage(f"--particles {' '.join(map(str, args.particles))}: Table 1's rows are "
                      f"{' '.join(map(str, rows))}")
    sweep = load_sweep(SWEEP)
    if args.eye != "wide":   # the same sweep on the other eye's scenario, in its own directory
        sweep.config.scenario = SCENARIOS_DIR / EYES[args.eye]
        sweep.config.name = f"{sweep.name}_{args.eye}"
    if args.particles is not None:
        sweep.config.cases = [c for c in sweep.config.cases
                              if c["trackers.kpf.n_particles"] in args.particles]
    if seeds is not None:
        sweep.config.seeds = seeds
    if args.duration is not None:
        sweep.config.set["duration"] = args.duration
    try:
        for item in args.set:
            key, value = parse_override(item)
            sweep.config.set[key] = value
        out = args.out or default_out_dir(sweep)
        planned = plan_sweep(sweep, out)   # every run's scenario validated before any runs
    except ScenarioError as err:
        return report_error(err)
    if not args.no_run:
        run_sweep(sweep, out, jobs=args.jobs, progress=True)
    if planned:
        sc = planned[0].scenario
        print(f"one eye camera: {sc.cameras.which}, {sc.cameras.resolution[0]} x "
              f"{sc.cameras.resolution[1]} at {sc.cameras.rate:g} Hz; the person "
              f"{sc.human.distance:g} m away")
    print(table(collect(planned)))
    return 0
