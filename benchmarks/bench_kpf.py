"""Speed of Schmidt et al.'s kernel-particle-filter tracker (``kpf``), rendering excluded: frames
per second (cue maps + one filter step; the maps over the image region the particles need,
``FrameCues``, as the tracker stage computes them) at the issue's configurations (particles,
mean-shift iterations) = (150, 2) and (1000, 3), on rendered frames of the side-pointing gesture
(320 x 240, 7.5 Hz), for the trackers of ``scenarios/schmidt_table1.yaml``: the paper's method
(``kpf_paper``), ours (``kpf``) and plain CONDENSATION. Goals (issue 14): >= 75 Hz at (150, 2),
>= 10 Hz at (1000, 3); the paper ran (150, 2) at 7.5 Hz on a 1.73 GHz Pentium M. Wall-clock
rates depend on what else runs on the machine; the rate per second of this thread's CPU time
(BLAS on one thread; OpenCV's own worker threads, in the cue maps and the cue sampling's
``cv2.remap``, not counted) is what one free core would give; ``--opencv-threads 1`` keeps
OpenCV on this thread too, so every operation of the tracker is counted. Each configuration
first tracks a frame untimed (warm-up: the compiled kernels' loading -- or compiling, with an
empty numba cache -- and the caches are not counted).

    PYTHONPATH=src MUJOCO_GL=egl python benchmarks/bench_kpf.py [--frames N] [--repeats R]
        [--opencv-threads N] [--same-seed] [--only NAME] [--config P,I]
"""

from __future__ import annotations

import argparse
import statistics
import time

import cv2
import numpy as np
from _frames import render_sequence

from humimic import bodymodel as bm
from humimic.paths import SCENARIOS_DIR
from humimic.perception.trackers.common import skin_model_lut
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.tracker import KpfTracker, kpf_body
from humimic.perception.trackers.kpf.warmup import load_kernels
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.sensors.camera_model import invert_transform
from humimic.world.world import World

HUMAN = {"distance": 2.0, "motion": {"kind": "point", "hand": "right", "gestures": ["side"],
                                     "move": 1.5, "hold": 2.0, "rest": 1.0}}


def bench_frames(n_frames: int, gesture: str = "side") -> dict:
    """The bench's ``frames`` ((image, T_cam_base) at 7.5 Hz of :data:`HUMAN` pointing
    (``gesture``: side or angle), left
    wide eye), their ``intrinsics``, the tracker's start ``q0`` (the truth) and skin ``lut``."""
    human = {**HUMAN, "motion": {**HUMAN["motion"], "gestures": [gesture]}}
    seq = render_sequence("kpf", human, n_frames / 7.5, cameras="left", rate=7.5)
    cam = seq.cameras[0]
    scenario = load_scenario(SCENARIOS_DIR / "schmidt_side.yaml", duration=0.2)
    world = World(scenario, Rngs(0))
    try:
        q0 = bm.truth_state(world, 0, "base")
        lut = skin_model_lut(scenario, world, [cam], "bench")
    finally:
        world.close()
    return {"frames": [(img, invert_transform(m.T_base_cam)) for img, m in
                       zip(seq.images[cam], seq.models[cam], strict=True)],
            "intrinsics": seq.models[cam][0].intrinsics, "q0": q0, "lut": lut}


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--frames", type=int, default=20)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--opencv-threads", type=int, default=None,
                   help="cv2.setNumThreads (default: OpenCV's own choice)")
    p.add_argument("--same-seed", action="store_true",
                   help="every repeat with seed 0 (the same work), and the rate of each "
                   "frame's least CPU time over the repeats (other processes' interference "
                   "-- cache, memory bandwidth, hyper-threads -- only ever adds time)")
    p.add_argument("--only", default=None,
                   help="one tracker of schmidt_table1.yaml (kpf, kpf_paper, condensation)")
    p.add_argument("--config", action="append", default=None, metavar="P,I",
                   help="(particles, iterations) to run (repeatable; default 150,2 and 1000,3)")
    args = p.parse_args()
    configs = [(150, 2), (1000, 3)] if args.config is None else [
        tuple(int(x) for x in c.split(",")) for c in args.config]
    if args.opencv_threads is not None:
        cv2.setNumThreads(args.opencv_threads)
    body = kpf_body()
    data = bench_frames(args.frames)
    frames, intr, q0, lut = data["frames"], data["intrinsics"], data["q0"], data["lut"]
    print(f"kpf tracker, {len(frames) - 1} frames of 320 x 240, median of {args.repeats} "
          "repeats (frames per second, cue maps + filter, rendering excluded)")
    variants = load_scenario(SCENARIOS_DIR / "schmidt_table1.yaml").trackers
    if args.only is not None:
        if args.only not in variants:
            p.error(f"--only: no tracker {args.only!r} (one of {', '.join(variants)})")
        variants = {args.only: variants[args.only]}
    for (n, it) in configs:
        for name, base in variants.items():
            cfg = base.model_copy(update={"n_particles": n, "iterations": it})
            rates, cpu_rates, per_frame = [], [], []
            load_kernels(body, intr, cfg, frames[0][0], lut, frames[0][1], q0)
            for r in range(args.repeats):
                tr = KpfTracker(body, intr, cfg, np.random.default_rng(0 if args.same_seed else r))
                kw = {"colour_gradients": cfg.colour_gradients}
                tr.start(q0, FrameCues(frames[0][0], lut, **kw), frames[0][1])
                t0, c0 = time.perf_counter(), time.thread_time()
                cpu = []
                for img, T in frames[1:]:
                    c1 = time.thread_time()
                    tr.step(FrameCues(img, lut, **kw), T)
                    cpu.append(time.thread_time() - c1)
                rates.append((len(frames) - 1) / (time.perf_counter() - t0))
                cpu_rates.append((len(frames) - 1) / (time.thread_time() - c0))
                per_frame.append(cpu)
            floor = ""
            if args.same_seed:   # the same work every repeat: its least CPU time per frame
                floor = f", {(len(frames) - 1) / np.min(per_frame, axis=0).sum():7.1f} Hz floor"
            print(f"  ({n:4d}, {it}) {name:13s} {statistics.median(rates):7.1f} Hz wall "
                  f"(q1-q3 {np.percentile(rates, 25):.1f}-{np.percentile(rates, 75):.1f}), "
                  f"{statistics.median(cpu_rates):7.1f} Hz of this thread's CPU time{floor}")


if __name__ == "__main__":
    main()
