"""Cost of the rerun logging in the simulation loop, and the .rrd size per simulated second.

    .venv/bin/python benchmarks/bench_viz.py [--seconds 4] [--noise 2.0] [--quality 80]

Prints the per-call wall time of ``RerunLog.log_poses`` (all moving bodies; poses are
buffered, so the mean is the amortised cost and the max is one flush),
``log_camera_image`` at 320x240 and the small overlay calls, then simulates the default
output settings -- stereo wide cameras at 60 Hz with ``image_every=2``, poses at 30 Hz --
and reports the recording's size per simulated second.
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import mujoco
import numpy as np

from humimic.sensors.cameras import CameraRig, CameraSpec
from humimic.viz.rerun_log import RerunLog, camera_entity, image_entity
from humimic.world.scene import build_scene

PHYSICS_HZ = 840
CAMERA_HZ = 60
POSE_HZ = 30
IMAGE_EVERY = 2


def per_call_us(fn, n: int) -> np.ndarray:
    """Wall time of each of ``n`` calls ``fn(i)`` in microseconds."""
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        fn(i)
        out[i] = time.perf_counter() - t0
    return out * 1e6


def report(name: str, us: np.ndarray) -> None:
    print(f"  {name:34s} mean {us.mean():8.1f} us   median {np.median(us):8.1f} us"
          f"   max {us.max():8.1f} us   (n={len(us)})")


def bench_calls(scene, rig, tmp: Path, quality: int) -> None:
    img = rig.capture(0.0)["L_wide"]
    with RerunLog(scene, "save", tmp / "calls.rrd", recording_id="bench-calls") as rlog:
        rlog.log_static_scene()
        print(f"per-call cost ({len(rlog.pose_entities)} moving bodies, 320x240 JPEG q={quality}):")
        report("log_poses", per_call_us(lambda i: rlog.log_poses(i / POSE_HZ), 3000))
        report("log_camera_image", per_call_us(
            lambda i: rlog.log_camera_image(i / 30, camera_entity("L_wide"), img, quality), 300))
        report("log_camera_image (raw, no JPEG)", per_call_us(
            lambda i: rlog.log_camera_image(i / 30, camera_entity("R_wide"), img, None), 100))
        cov2 = np.tile(np.diag([40.0, 15.0]), (3, 1, 1))
        uv = np.array([[100.0, 80.0], [200.0, 120.0], [150.0, 60.0]])
        report("log_ellipses_2d (3 blobs)", per_call_us(lambda i: rlog.log_ellipses_2d(
            i / 30, image_entity("L_wide") + "/blobs", uv, cov2), 1000))
        cov3 = np.tile(np.diag([1e-4, 4e-4, 9e-4]), (3, 1, 1))
        p = np.array([[1.2, 0.0, 1.6], [1.1, -0.3, 1.1], [1.1, 0.3, 1.1]])
        report("log_ellipsoids_3d (3)", per_call_us(lambda i: rlog.log_ellipsoids_3d(
            i / 30, "world/estimates/targets", p, cov3), 1000))
        report("log_points (3)", per_call_us(lambda i: rlog.log_points(
            i / 30, "world/truth/targets", p), 1000))
        report("log_scalar", per_call_us(lambda i: rlog.log_scalar(
            i / 30, "series/err", 0.01 * i), 1000))
    off = RerunLog(scene, "off", None, recording_id="bench-off")
    report("log_poses, mode off", per_call_us(lambda i: off.log_poses(i / POSE_HZ), 3000))
    report("log_camera_image, mode off", per_call_us(
        lambda i: off.log_camera_image(i / 30, camera_entity("L_wide"), img, quality), 300))


def bench_size(scene, rig, tmp: Path, seconds: float, quality: int) -> None:
    m, d = scene.model, scene.data
    static_path, run_path = tmp / "static.rrd", tmp / "run.rrd"
    with RerunLog(scene, "save", static_path, recording_id="bench-static") as rlog:
        rlog.log_static_scene()
    r_shoulder = m.jnt_qposadr[m.joint("human/r_shoulder").id]
    frames = 0
    wall0 = time.perf_counter()
    with RerunLog(scene, "save", run_path, recording_id="bench-size") as rlog:
        rlog.log_static_scene()
        for tick in range(int(seconds * PHYSICS_HZ)):
            t = tick / PHYSICS_HZ
            angle = 0.8 * np.sin(2 * np.pi * 0.5 * t)  # the arm swings so images change
            d.qpos[r_shoulder:r_shoulder + 4] = [np.cos(angle / 2), np.sin(angle / 2), 0, 0]
            mujoco.mj_step1(m, d)
            if tick % (PHYSICS_HZ // CAMERA_HZ) == 0:
                images = rig.capture(t)
                if frames % IMAGE_EVERY == 0:
                    for name, img in images.items():
                        rlog.log_camera_image(t, camera_entity(name), img, quality)
                frames += 1
            if tick % (PHYSICS_HZ // POSE_HZ) == 0:
                rlog.log_poses(t)
            mujoco.mj_step2(m, d)
    wall = time.perf_counter() - wall0
    static_kb = static_path.stat().st_size / 1e3
    run_kb = run_path.stat().st_size / 1e3
    print(f".rrd size, stereo 320x240 @ {CAMERA_HZ} Hz, image_every={IMAGE_EVERY}, "
          f"JPEG q={quality}, noise_std={rig.specs[0].noise_std}, poses @ {POSE_HZ} Hz:")
    print(f"  static scene {static_kb:.0f} kB; run of {seconds:g} sim s {run_kb:.0f} kB "
          f"-> {(run_kb - static_kb) / seconds:.0f} kB per simulated second "
          f"(loop incl. rendering {wall:.1f} s wall)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=4.0, help="simulated seconds for the size")
    ap.add_argument("--noise", type=float, default=2.0, help="camera pixel noise std")
    ap.add_argument("--quality", type=int, default=80, help="JPEG quality")
    args = ap.parse_args()
    scene = build_scene()
    specs = [CameraSpec(n, 320, 240, noise_std=args.noise) for n in ("L_wide", "R_wide")]
    rig = CameraRig(scene, specs, np.random.default_rng(0))
    try:
        with tempfile.TemporaryDirectory() as tmp:
            bench_calls(scene, rig, Path(tmp), args.quality)
            bench_size(scene, rig, Path(tmp), args.seconds, args.quality)
    finally:
        rig.close()


if __name__ == "__main__":
    main()
