"""World benchmarks: physics step, eye- and head-camera rendering, the world loops' real-time
factors (Ude's stereo robot, Sugiyama's wearer), ground-truth samples per second.

Run: ``python benchmarks/bench_world.py [--repeats N] [--json PATH]``. Prints a table of
median and spread (interquartile range) over repeats, and writes JSON.
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import argparse
import json
import platform
import statistics
import tempfile
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import mujoco
import numpy as np
from rich.console import Console
from rich.table import Table

from _harness import per_call
from humimic.sensors.cameras import CameraRig, CameraSpec
from humimic.world.scene import SceneOptions, build_scene


def bench_physics(repeats: int) -> list[float]:
    scene = build_scene()
    m, d = scene.model, scene.data
    return per_call(lambda: mujoco.mj_step(m, d), repeats, 840)


def bench_render(repeats: int, cameras: list[str], size: tuple[int, int]) -> list[float]:
    scene = build_scene(SceneOptions(eye_resolution=size))
    mujoco.mj_forward(scene.model, scene.data)
    rig = CameraRig(scene, [CameraSpec(c, *size) for c in cameras], np.random.default_rng(0))
    try:
        # the warm-up call creates the GL context and uploads textures
        return per_call(lambda: rig.capture(0.0), repeats, 50)
    finally:
        rig.close()


def bench_ground_truth(repeats: int, n: int = 8400) -> list[float]:
    """Ground-truth samples per second (the person's every site, p/v/a, sensors): a 10 s wave
    at 840 Hz. Goal >= 20,000 samples/s (measured ~35,000 on the 2-core machine)."""
    import time

    from humimic.motion.config import WaveMotion
    from humimic.motion.context import MotionContext
    from humimic.motion.factory import make_motion
    from humimic.motion.ground_truth import compute_ground_truth
    from humimic.motion.trajectory import JointTrajectory

    scene = build_scene()
    ctx = MotionContext.from_scene(scene, n / 840.0, np.random.default_rng(0))
    traj = JointTrajectory.from_motion(make_motion(WaveMotion(), ctx), n / 840.0)
    t = np.arange(n) / 840.0
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        compute_ground_truth(scene, traj, t)
        out.append(n / (time.perf_counter() - t0))
    return out


def bench_world_loop(repeats: int, duration: float = 3.0) -> list[float]:
    """Real-time factor of the world alone (no stages): wide stereo at 60 Hz, 320x240."""
    from humimic.run import run_one
    from humimic.scenario import validate_scenario

    scenario = validate_scenario({
        "name": "bench-world", "duration": duration,
        "human": {"motion": {"kind": "wave"}},
        "cameras": {"which": "wide", "resolution": [320, 240], "rate": 60},
        "output": {"rerun": "off", "plots": False},
    })
    out = []
    for i in range(repeats):
        out_dir = Path(tempfile.gettempdir()) / f"humimic-bench-{i}"
        metrics = run_one(scenario, out_dir=out_dir, rerun="off", progress=False)
        out.append(metrics["realtime_factor"])
    return out


def bench_headcam(repeats: int) -> list[float]:
    """The wearable head camera in its room: 368x240, radial distortion, pixel noise."""
    scene = build_scene(SceneOptions(room="sugiyama", show_wiimote=True))
    mujoco.mj_forward(scene.model, scene.data)
    rig = CameraRig(scene, [CameraSpec("headcam", 368, 240, 2.0, -0.15, 0.02)],
                    np.random.default_rng(0), show_wiimote=True)
    try:
        return per_call(lambda: rig.capture(0.0), repeats, 50)
    finally:
        rig.close()


def bench_wearable_loop(repeats: int, duration: float = 4.0) -> list[float]:
    """Real-time factor of the wearable world alone (scenarios/wearable_walk.yaml, its first
    ``duration`` s: head camera 30 Hz with the corner-counting probe, IMU 180 Hz, Wii 100 Hz)."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    scenario = load_scenario(SCENARIOS_DIR / "wearable_walk.yaml", duration=duration,
                             overrides=["output.plots=false"])
    return [run_one(scenario, out_dir=Path(tempfile.gettempdir()) / f"humimic-bench-wearable-{i}",
                    rerun="off", progress=False)["realtime_factor"] for i in range(repeats)]


def _row(name: str, values: list[float], unit: str, scale: float = 1.0) -> dict:
    v = sorted(x * scale for x in values)
    q = statistics.quantiles(v, n=4) if len(v) >= 2 else [v[0], v[0], v[0]]
    return {"name": name, "unit": unit, "median": statistics.median(v), "q1": q[0],
            "q3": q[2], "repeats": len(v)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--json", type=Path, default=Path("benchmarks/results/world.json"))
    args = ap.parse_args()
    r = args.repeats
    rows = [
        _row("physics step (robot + avatar, 70 DOF)", bench_physics(r), "us", 1e6),
        _row("render 1 eye camera 320x240", bench_render(r, ["L_wide"], (320, 240)), "ms", 1e3),
        _row("render 1 eye camera 640x480", bench_render(r, ["L_wide"], (640, 480)), "ms", 1e3),
        _row("render stereo pair 320x240", bench_render(r, ["L_wide", "R_wide"], (320, 240)),
             "ms", 1e3),
        _row("render all 4 eye cameras 320x240",
             bench_render(r, ["L_wide", "R_wide", "L_foveal", "R_foveal"], (320, 240)), "ms",
             1e3),
        _row("world loop, wide stereo 60 Hz 320x240", bench_world_loop(max(3, r // 2)),
             "x real time"),
        _row("render head camera 368x240 (wearable room, distortion, noise)",
             bench_headcam(r), "ms", 1e3),
        _row("world loop, wearable walk (head camera 30 Hz, IMU, Wii)",
             bench_wearable_loop(max(3, r // 2)), "x real time"),
        _row("ground truth, 10 s wave at 840 Hz (goal >= 20,000)",
             bench_ground_truth(max(3, r // 2)), "samples/s"),
    ]
    table = Table(title=f"humimic world benchmarks ({platform.processor() or platform.machine()},"
                        f" {__import__('os').cpu_count()} cores)")
    for col in ("benchmark", "median", "IQR", "unit", "repeats"):
        table.add_column(col)
    for row in rows:
        table.add_row(row["name"], f"{row['median']:.3g}", f"{row['q1']:.3g}-{row['q3']:.3g}",
                      row["unit"], str(row["repeats"]))
    Console().print(table)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"machine": platform.platform(), "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
