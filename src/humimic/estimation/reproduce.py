"""Reproduce Sugiyama & Miura's movement-estimation results and print them beside the paper's.

``python -m humimic.estimation.reproduce table2|fig8|cycle|arm-mask [--out DIR] [--seed N]
[--duration S] [--run DIR]``

* ``table2`` -- runs ``scenarios/sugiyama_table2.yaml`` (the wearer visits the table's four
  positions) and prints, per position, the paper's estimate and error beside ours (against
  the true head and against the stand point, the paper's comparison). ``--run DIR`` reads a
  finished run's ``slam.npz`` instead.
* ``fig8`` -- the jump of ``scenarios/sugiyama_fig8.yaml`` estimated three ways (``slam.mode``
  fusion, camera, inertial): position and heading errors, matched features per frame, frames
  without a feature.
* ``cycle`` -- records the Table II walk's sensors once (``--duration``, default 12 s) and runs
  the estimator over them with 20 and 40 features in the map (``slam.max_map``): the mean
  cycle per frame (IMU updates, arm mask, undistortion, search, EKF, map management,
  detection; no rendering) beside the paper's 36.7 and 43.3 ms.
* ``arm-mask`` -- ``scenarios/sugiyama_arm_mask.yaml`` (the Wii remote held out in view while
  the wearer steps and looks around), recorded once and estimated with ``slam.mask_arm`` on
  and off: features initialised on the wearer's arm and the position error (the paper leaves
  this problem open).
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse
import sys
from pathlib import Path

import numpy as np

from humimic.errors import InputError, report_error
from humimic.paths import SCENARIOS_DIR

SCENARIOS = {"table2": "sugiyama_table2.yaml", "fig8": "sugiyama_fig8.yaml",
             "cycle": "sugiyama_table2.yaml", "arm-mask": "sugiyama_arm_mask.yaml"}


def _run(name: str, out: Path | None, seed, duration, overrides=()) -> tuple[Path, dict]:
    from humimic.run import default_out_dir, run_one
    from humimic.scenario import load_scenario

    scenario = load_scenario(SCENARIOS_DIR / name, list(overrides), seed=seed,
                             duration=duration)
    out = out or default_out_dir(scenario)
    return out, run_one(scenario, out, rerun="off", progress=sys.stdout.isatty())


def table2(args) -> list:
    import yaml

    from humimic.estimation.ekf.sugiyama_tables import format_table2, standing_intervals
    from humimic.estimation.ekf.sugiyama_tables import table2 as rows_of

    if args.run is not None:
        out = args.run
        if not (out / "slam.npz").is_file():
            raise InputError(f"--run: no slam.npz in {out} (run a scenario with slam: first)")
        metrics = None
    else:
        out, metrics = _run(SCENARIOS["table2"], args.out, args.seed, args.duration)
    motion = yaml.safe_load((out / "scenario.resolved.yaml").read_text())["human"]["motion"]
    waypoints = [(w["t"], tuple(w["at"])) for w in motion.get("waypoints", [])]
    tr = dict(np.load(out / "slam.npz"))
    rows = rows_of(tr, standing_intervals(waypoints))
    print("Table II -- the user's position and the estimated interface (head camera) position "
          "in W, (x, z) m; ours averaged over each stand")
    print(format_table2(rows))
    if metrics is not None:
        s = metrics["slam"]
        print(f"whole walk ({s['frames']} frames): ATE {100 * s['ate_rmse_m']:.1f} cm "
              f"(horizontal {100 * s['horizontal_rmse_m']:.1f} cm), heading "
              f"{s['heading_rmse_deg']:.2f} deg; paper: errors 0.09-0.24 m")
    print("'err head': our estimate against the true head camera; 'err user': against the "
          "stand point, as the paper compared (the head is ~0.1 m ahead of the feet)")
    return rows


def fig8(args) -> dict:
    from humimic.estimation.ekf.sugiyama_tables import PAPER_FIG8, fig8_row

    out0 = args.out or Path("runs") / "sugiyama_fig8"
    res = {}
    for mode in ("fusion", "camera", "inertial"):
        _, m = _run(SCENARIOS["fig8"], out0 / mode, args.seed, args.duration,
                    [f"slam.mode={mode}"])
        res[mode] = fig8_row(m["slam"])
    print("Fig. 8 -- jumping at the start position, estimated three ways")
    print(f"{'':9} {'ATE cm':>7} {'vert cm':>8} {'max cm':>7} {'head deg':>9} "
          f"{'feat/frame':>10} {'no-feat frames':>14}  paper")
    for mode, r in res.items():
        print(f"{mode:9} {100 * r['ate_rmse_m']:7.1f} {100 * r['vertical_rmse_m']:8.1f} "
              f"{100 * r['position_max_error_m']:7.1f} {r['heading_rmse_deg']:9.2f} "
              f"{r['features_per_frame']:10.1f} {r['frames_without_features']:14d}  "
              f"{PAPER_FIG8[mode]}")
    return res


def _recorded(args, which: str):
    from humimic.estimation.ekf.replay import record
    from humimic.scenario import load_scenario

    scenario = load_scenario(SCENARIOS_DIR / SCENARIOS[which], seed=args.seed)
    duration = args.duration or min(scenario.duration, 12.0)
    print(f"recording {duration:g} s of {scenario.name} (head camera, IMU) ...", flush=True)
    return record(scenario, duration, progress=sys.stdout.isatty())


def cycle(args, log=None) -> dict:
    from humimic.estimation.ekf.replay import replay
    from humimic.estimation.ekf.sugiyama_tables import PAPER_CYCLE_MS

    log = log or _recorded(args, "cycle")
    res = {}
    print(f"{'features':>8} {'cycle ms mean':>13} {'median':>7} {'p95':>6} {'CPU ms':>7} "
          f"{'ATE cm':>7}  paper")
    for n in (20, 40):
        cfg = log.scenario.slam.model_copy(update={"target_features": n, "max_map": n})
        stage = replay(log, cfg)
        arr = stage.record.arrays()
        c, cpu = 1e3 * arr["cycle_s"], 1e3 * arr["cycle_cpu_s"]
        s = stage.metrics()["slam"]
        res[n] = {"mean_ms": float(c.mean()), "median_ms": float(np.median(c)),
                  "p95_ms": float(np.percentile(c, 95)), "cpu_ms": float(cpu.mean()),
                  "ate_rmse_m": s["ate_rmse_m"]}
        print(f"{n:8d} {c.mean():13.2f} {np.median(c):7.2f} {np.percentile(c, 95):6.2f} "
              f"{cpu.mean():7.2f} {100 * s['ate_rmse_m']:7.1f}  {PAPER_CYCLE_MS[n]} ms")
    print("wall time per frame on this machine, shared with whatever else runs, and the "
          "estimator thread's CPU time (the paper: a 1.33 GHz Core 2 Duo)")
    return res


def arm_mask(args, log=None) -> dict:
    from humimic.estimation.ekf.replay import replay

    log = log or _recorded(args, "arm-mask")
    res = {}
    print(f"{'mask_arm':>8} {'features on arm':>15} {'ATE cm':>7} {'heading deg':>11}")
    for on in (True, False):
        stage = replay(log, log.scenario.slam.model_copy(update={"mask_arm": on}))
        s = stage.metrics()["slam"]
        res[on] = s
        print(f"{str(on):>8} {s['features_added_on_arm']:15d} {100 * s['ate_rmse_m']:7.2f} "
              f"{s['heading_rmse_deg']:11.2f}")
    return res


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m humimic.estimation.reproduce",
                                description=__doc__.split("\n")[0])
    p.add_argument("which", choices=sorted(SCENARIOS))
    p.add_argument("--out", type=Path, default=None, help="run directory")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--duration", type=float, default=None, help="override duration (s)")
    p.add_argument("--run", type=Path, default=None, help="table2: read this finished run")
    args = p.parse_args(argv)
    try:
        {"table2": table2, "fig8": fig8, "cycle": cycle, "arm-mask": arm_mask}[args.which](args)
    except (InputError, ValueError) as err:
        return report_error(err)
    return 0


if __name__ == "__main__":
    sys.exit(main())
