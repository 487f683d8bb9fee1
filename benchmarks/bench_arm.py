"""Sugiyama & Miura's arm EKF and robot commands: costs and the reproductions' numbers.

    .venv/bin/python benchmarks/bench_arm.py [--repeats 5] [--quick]

Rows: the arm EKF's filter work per head-camera frame (one marker update and the ~3.3 Wii
samples before it, synthetic data), the marker extraction on a rendered 368x240 frame, the
SLAM and the arm EKF running together per frame (paper: 43.2 ms on a 1.33 GHz Core 2 Duo), and
the real-time factor of the whole wearable scenarios (rendering, SLAM, arm EKF, commands and
the robot; goal >= 2x). The Fig. 3 depth error (paper ~3 cm, goal 1.5 cm) and Fig. 10's command
counts are reported beside them. On a shared machine wall times grow with the load; every
row is therefore also measured in this process's CPU time (``cpu`` rows), which is what a
quiet machine's wall time would be (the pipeline is single-threaded: MuJoCo renders with one
llvmpipe thread, OMP_NUM_THREADS=1).
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import Row, fmt, row  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
FIG3 = ROOT / "scenarios" / "sugiyama_fig3_arm_forward.yaml"
FIG10 = ROOT / "scenarios" / "sugiyama_fig10_robot_control.yaml"


def bench_filter(repeats: int) -> Row:
    """Filter work per frame on tests/_arm_synth's data (no images)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from _arm_synth import RADIUS, ArmMotion, measurements

    from humimic.estimation.ekf.arm import ArmEKF, Marker
    from humimic.sensors.camera_model import Intrinsics

    K = Intrinsics.from_fovy(np.radians(50.0), 368, 240)
    m = ArmMotion()
    events = measurements(m, 10.0, K, np.random.default_rng(0))
    R_WI = {t: m.R_WI(t).as_matrix()[0] for t, kind, _ in events if kind == "marker"}
    frames = sum(kind == "marker" for _, kind, _ in events)

    def run():
        ekf = ArmEKF(K, Marker(radius=RADIUS))
        for t, kind, val in events:
            if kind == "marker":
                ekf.on_marker(t, *val, R_WI[t])
            else:
                ekf.on_wii(t, *val)
    wall, cpu = timed(run, repeats)
    return [row("arm", "arm EKF per frame (1 marker + 3.3 Wii samples)",
                [s / frames for s in wall], "ms", 1e3, note="synthetic, no images"),
            row("arm", "  cpu", [s / frames for s in cpu], "ms", 1e3)]


def timed(fn, repeats: int, inner: int = 1) -> tuple[list[float], list[float]]:
    """Wall and CPU seconds per call of ``fn`` over ``repeats`` x ``inner`` calls."""
    wall, cpu = [], []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        for _ in range(inner):
            fn()
        wall.append((time.perf_counter() - w0) / inner)
        cpu.append((time.process_time() - c0) / inner)
    return wall, cpu


def rendered_frames(n: int = 20):
    """Head-camera frames of the Fig. 3 scenario (the marker and the room's posters)."""
    import mujoco

    from humimic.rngs import Rngs
    from humimic.scenario import load_scenario
    from humimic.world.world import World

    sc = load_scenario(FIG3, overrides=["slam=null"])
    w = World(sc, Rngs(sc.seed))
    out = []
    for t in np.linspace(0.5, sc.duration - 0.5, n):
        w.apply_human(int(round(t * sc.timing.physics_rate)))
        mujoco.mj_forward(w.scene.model, w.scene.data)
        out.append(w.capture_headcam(float(t)).image)
    K = w.head_rig.intrinsics("headcam")
    w.close()
    return out, K


def bench_marker(repeats: int) -> Row:
    from humimic.estimation.ekf.arm_marker import marker_candidates

    frames, K = rendered_frames()
    i = iter(range(10**9))

    def run():
        marker_candidates(frames[next(i) % len(frames)], K)
    run()
    wall, cpu = timed(run, repeats, 50)
    return [row("arm", "marker extraction 368x240 (hue, labels, shape)", wall, "ms", 1e3,
                note="rendered Fig. 3 frames"), row("arm", "  cpu", cpu, "ms", 1e3)]


def run_scenario(path: Path, duration: float, overrides: list[str]) -> dict:
    """``run_one``'s metrics plus ``cpu_realtime_factor``: simulated over CPU seconds of the
    loop (the run's wall time minus its setup, scaled by CPU / wall over the whole run)."""
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(path, overrides=overrides, duration=duration)
    with tempfile.TemporaryDirectory() as out:
        w0, c0 = time.perf_counter(), time.process_time()
        m = run_one(sc, out, rerun="off", progress=False)
        cpu_share = (time.process_time() - c0) / (time.perf_counter() - w0)
    m["cpu_realtime_factor"] = m["sim_time_s"] / (m["loop_wall_time_s"] * cpu_share)
    m["cpu_share"] = cpu_share
    return m


def bench_scenarios(repeats: int, duration: float) -> list[Row]:
    rows = []
    runs = [run_scenario(FIG3, duration, []) for _ in range(repeats)]
    slam = [r["slam"]["cycle_ms"] for r in runs]
    arm = [r["arm"]["cycle_ms"] for r in runs]
    rows.append(row("arm", "SLAM cycle per frame (Fig. 3 run)", slam, "ms",
                    note="slam.cycle_ms; paper 36.7 ms at 20 features"))
    rows.append(row("arm", "arm EKF cycle per frame (Fig. 3 run)", arm, "ms",
                    note="arm.cycle_ms: marker extraction + filter"))
    both = [a + b for a, b in zip(slam, arm, strict=True)]
    rows.append(row("arm", "SLAM + arm EKF per frame", both, "ms",
                    note="paper 43.2 ms (1.33 GHz Core 2 Duo)"))
    rows.append(row("arm", "  cpu (scaled by the run's CPU / wall)",
                    [b * r["cpu_share"] for b, r in zip(both, runs, strict=True)], "ms"))
    rows.append(row("arm", "Fig. 3 depth error (arm stretched forward)",
                    [r["arm"]["depth_rmse_m"] for r in runs], "cm", 100.0,
                    note="arm.depth_rmse_m; paper ~3 cm, goal 1.5 cm"))
    rows.append(row("arm", f"Fig. 3 scenario, {duration:g} s", [r["realtime_factor"]
                                                                for r in runs],
                    "x real time", note="render + SLAM + arm EKF; goal >= 2"))
    rows.append(row("arm", "  cpu", [r["cpu_realtime_factor"] for r in runs], "x real time"))
    runs = [run_scenario(FIG10, duration * 2, []) for _ in range(max(1, repeats // 2))]
    rows.append(row("arm", f"Fig. 10 scenario, {2 * duration:g} s",
                    [r["realtime_factor"] for r in runs], "x real time",
                    note="render + SLAM + arm EKF + commands + robot; goal >= 2",
                    commands=runs[0]["commands"]["count"]))
    rows.append(row("arm", "  cpu", [r["cpu_realtime_factor"] for r in runs], "x real time"))
    return rows


def main(argv: list[str] | None = None) -> int:
    from rich.console import Console
    from rich.table import Table

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--quick", action="store_true", help="fewer repeats, shorter runs")
    a = p.parse_args(argv)
    repeats = 3 if a.quick else a.repeats
    load0 = os.getloadavg()
    rows = bench_filter(repeats) + bench_marker(repeats)
    rows += bench_scenarios(max(1, repeats // 2), 4.0 if a.quick else 8.0)
    table = Table(title=f"arm EKF and commands (load {load0[0]:.1f} -> "
                        f"{os.getloadavg()[0]:.1f})")
    for col in ("measure", "median", "q1-q3", "unit", "note"):
        table.add_column(col)
    for r in rows:
        table.add_row(r.name, fmt(r.median), f"{fmt(r.q1)}-{fmt(r.q3)}", r.unit,
                      r.note + (f" {r.extra}" if r.extra else ""))
    Console().print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
