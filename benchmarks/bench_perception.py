"""Cost of Ude & Atkeson's perception: per-frame compute of each part, and what the perception
stage adds to the simulation loop.

Run from the project root::

    .venv/bin/python benchmarks/bench_perception.py [--frames 240] [--loop-seconds 6] [--quick]

Part 1 (synthetic, no renderer): four skin ellipses moving over a textured wall 3 m away, seen
by a non-rectified, distorted 320x240 stereo head (tests/_synth_vision.py). Median per-frame
cost of EM tracking with 1, 2 and 4 blobs (one image), stereo matching + triangulation of 4
targets, the 4 random-jerk filters, and a whole stereo frame (EM in both images, rig, stereo,
filters) -> stereo frames per second of compute (goal: >= 600 with 4 blobs).

Part 2 (the real loop): ``scenarios/ude_wave_tracking.yaml`` (60 Hz stereo, 320x240, rerun
off) without its perception and filter sections, with them synchronous, pipelined in a worker
thread and pipelined in a worker process (the default for runs of 2 s or more); the loop's wall
time per camera frame and the fraction perception adds (goal: <= 30 %).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from _synth_vision import (  # noqa: E402
    SKIN_RGB,
    TexturedPlane,
    add_noise,
    draw_ellipse,
    stereo_head,
)

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

from humimic.estimation.random_jerk import RandomJerkFilter  # noqa: E402
from humimic.perception.blobs.em_blobs import BlobTracker  # noqa: E402
from humimic.perception.blobs.stereo import StereoRig  # noqa: E402
from humimic.perception.cues.color_models import ColorLUT, fit_color_model  # noqa: E402

BASE = np.array([[1.0, 0.25, 1.35], [1.0, -0.25, 1.35], [1.1, 0.2, 1.0], [1.1, -0.2, 1.0]])
AXES = [(10, 7), (8, 12), (14, 9), (9, 9)]
C_PX = 0.3**2 * np.eye(2)
#: Part 2's configurations with perception (see part_two).
LABELS = ("synchronous", "thread", "process")


def points(f: int) -> np.ndarray:
    """True base-frame positions of the four blobs at frame ``f`` (m)."""
    phase = np.arange(4)[:, None] + np.array([0.0, 1.1, 2.2])
    return BASE + 0.1 * np.sin(2 * np.pi * f / 90 + phase)


def synthetic_frames(n: int, rng: np.random.Generator):
    cam_l, cam_r = stereo_head()
    wall = TexturedPlane(np.random.default_rng(2), origin=(3.0, 0.0, 1.2), e1=(0, -1, 0),
                         e2=(0, 0, -1), size_m=4.0, tex_px=800)
    bg_l, bg_r = wall.render(cam_l), wall.render(cam_r)
    frames = []
    for f in range(n):
        P = points(f)
        il, ir = bg_l.copy(), bg_r.copy()
        for k in range(4):
            draw_ellipse(il, cam_l.project_base(P[k]), AXES[k], 20 * k)
            draw_ellipse(ir, cam_r.project_base(P[k]), AXES[k], 20 * k)
        frames.append((add_noise(il, rng, 4.0), add_noise(ir, rng, 4.0)))
    return cam_l, cam_r, frames


def median_us(samples: list[float], skip: int = 10) -> float:
    return 1e6 * statistics.median(samples[skip:])


def started(lut, K: int, cam) -> BlobTracker:
    tr = BlobTracker([lut] * K)
    for k in range(K):
        tr.start(k, cam.project_base(points(0)[k]), 25 * np.eye(2))
    return tr


def part_one(n_frames: int) -> dict[str, float]:
    rng = np.random.default_rng(0)
    patch = add_noise(np.full((60, 60, 3), SKIN_RGB, np.uint8), rng, 4.0)
    lut = ColorLUT(fit_color_model(patch.reshape(-1, 3), "rgb", 1, np.random.default_rng(1)))
    cam_l, cam_r, frames = synthetic_frames(n_frames, rng)
    out: dict[str, float] = {}
    for K in (1, 2, 4):
        tr = started(lut, K, cam_l)
        ts = []
        for il, _ in frames:
            t0 = time.perf_counter()
            tr.update(il)
            ts.append(time.perf_counter() - t0)
        out[f"em_{K}_blobs_us"] = median_us(ts)
    trl, trr = started(lut, 4, cam_l), started(lut, 4, cam_r)
    filters = [RandomJerkFilter() for _ in range(4)]
    parts: dict[str, list[float]] = {k: [] for k in ("em_left", "em_right", "stereo", "filters",
                                                      "total")}
    errors = []
    for f, (il, ir) in enumerate(frames):
        t0 = time.perf_counter()
        fl = trl.update(il)
        t1 = time.perf_counter()
        fr = trr.update(ir)
        t2 = time.perf_counter()
        ms = StereoRig(cam_l, cam_r).match_many(il, ir, fl.centres, fl.covs, fr.centres,
                                                fr.covs, C_PX, C_PX, [lut] * 4, 0.1)
        t3 = time.perf_counter()
        for kf, m in zip(filters, ms, strict=True):
            kf.step(f / 60.0, m.p_base if m.ok else None, m.R_base if m.ok else None)
        t4 = time.perf_counter()
        for key, a, b in (("em_left", t0, t1), ("em_right", t1, t2), ("stereo", t2, t3),
                          ("filters", t3, t4), ("total", t0, t4)):
            parts[key].append(b - a)
        if f >= 10:
            errors += [np.linalg.norm(m.p_base - p) for m, p in zip(ms, points(f), strict=True)
                       if m.ok]
    out.update({f"{k}_us": median_us(v) for k, v in parts.items()})
    out["stereo_frames_per_s"] = 1e6 / out["total_us"]
    out["median_3d_error_mm"] = 1e3 * float(np.median(errors))
    return out


def part_two(seconds: float, repeats: int) -> dict[str, float]:
    """Loop wall time per camera frame without perception, with it synchronous and with it
    pipelined (latency one frame, processed while the next frame renders) in a thread and in a
    process. The configurations alternate ``repeats`` times; the fastest run of each counts
    (other load on the machine only ever slows a run down)."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    configs = {"without": ["perception=null", "filter=null"],
               "synchronous": ["perception.pipelined=off"],
               "thread": ["perception.pipelined=thread"],
               "process": ["perception.pipelined=process"]}
    best: dict[str, dict] = {}
    for _ in range(repeats):
        for label, sets in configs.items():
            scenario = load_scenario(SCENARIOS_DIR / "ude_wave_tracking.yaml", sets,
                                     duration=seconds)
            scenario.output.plots = False
            out_dir = Path(tempfile.gettempdir()) / f"bench_perception_{label}"
            m = run_one(scenario, out_dir, rerun="off", progress=False)
            per_frame = m["loop_wall_time_s"] / m["frames"]
            if label not in best or per_frame < best[label]["per_frame"]:
                best[label] = {"per_frame": per_frame, "metrics": m}
    out = {}
    for label, b in best.items():
        out[f"loop_ms_per_frame_{label}"] = 1e3 * b["per_frame"]
        out[f"realtime_factor_{label}"] = b["metrics"]["realtime_factor"]
        stages = b["metrics"]["stages"]
        if "perception" in stages:
            out[f"perception_ms_{label}"] = stages["perception"]["mean_ms"]
            out[f"filter_ms_{label}"] = stages["filter"]["mean_ms"]
    for label in LABELS:
        out[f"adds_{label}"] = (out[f"loop_ms_per_frame_{label}"]
                                / out["loop_ms_per_frame_without"] - 1.0)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--frames", type=int, default=240, help="synthetic frames (part 1)")
    p.add_argument("--loop-seconds", type=float, default=6.0, help="simulated s (part 2)")
    p.add_argument("--repeats", type=int, default=2, help="runs per configuration (part 2)")
    p.add_argument("--quick", action="store_true", help="part 1 only")
    args = p.parse_args(argv)
    one = part_one(args.frames)
    print("Part 1: synthetic 320x240 stereo, 4 skin blobs over texture (median per frame)")
    for K in (1, 2, 4):
        print(f"  EM tracker, {K} blob(s), one image       {one[f'em_{K}_blobs_us']:8.1f} us")
    print(f"  stereo match + triangulation, 4 targets {one['stereo_us']:8.1f} us")
    print(f"  4 random-jerk filters (predict+update)  {one['filters_us']:8.1f} us")
    print(f"  whole stereo frame (EM x2, stereo, KF)  {one['total_us']:8.1f} us  -> "
          f"{one['stereo_frames_per_s']:.0f} stereo frames/s (goal >= 600)")
    print(f"  median raw 3-D error                    {one['median_3d_error_mm']:8.2f} mm")
    if not args.quick:
        two = part_two(args.loop_seconds, args.repeats)
        print("Part 2: scenarios/ude_wave_tracking.yaml, 60 Hz stereo 320x240, rerun off "
              f"(best of {args.repeats})")
        print(f"  loop without perception   {two['loop_ms_per_frame_without']:6.2f} ms/frame "
              f"(realtime x{two['realtime_factor_without']:.2f})")
        for label in LABELS:
            print(f"  loop, perception {label:11s}{two[f'loop_ms_per_frame_{label}']:6.2f} "
                  f"ms/frame (realtime x{two[f'realtime_factor_{label}']:.2f}); perception "
                  f"{two[f'perception_ms_{label}']:.2f} ms, filter "
                  f"{two[f'filter_ms_{label}']:.2f} ms per frame; adds "
                  f"{100 * two[f'adds_{label}']:.1f} % (goal <= 30 %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
