"""A/B speed of the kpf tracker in two source trees (e.g. main's and a branch's), interleaved.

On a machine shared with other work a single benchmark's rate drifts with the load by more
than a change's gain; comparing two trees run one after the other in alternating order (A B,
B A, A B, ...), each run in a fresh subprocess importing its tree (``PYTHONPATH``), puts both
under the same load. Every run tracks the same rendered frames (rendered once, by tree A's
code, and handed to the runs in a pickle) with the same seed, and reports the rate per second
of its thread's CPU time (OpenCV on this thread: ``cv2.setNumThreads(1)``, so every operation
is counted), the kernels loaded before timing (:func:`~humimic.perception.trackers.kpf.warmup.
load_kernels`). Per run three rates: ``median`` (of the repeats' rates) and ``floor`` (of each
frame's least CPU time over the repeats: other processes' interference only ever adds time),
and ``wall`` (frames per wall-clock second: the one that counts work on other threads; honest
only while the machine has a core to spare). Printed: each
tree's median over the rounds (and quartiles) and the ratio B / A of the medians and the median
of the per-round ratios.

    MUJOCO_GL=egl python benchmarks/bench_kpf_ab.py BASELINE_CHECKOUT/src src \\
        [--rounds R] [--config P,I] [--only NAME] [--frames N] [--repeats K]
        [--gesture side|angle] [--fovea] [--fovgaze [--set-a K=V] [--set-b K=V]]

``--fovea``: the frames of ``scenarios/schmidt_table1_fovgaze.yaml`` (the left eye's wide and
foveal cameras, the eye on the true right elbow) and tree B's runs with the scenario's
``trackers.kpf.fovea`` (give the same tree twice to measure the fovea's cost).
``--fovgaze``: those frames, and both trees' runs with the scenario's whole ``kpf`` (its fovea
and flip-branch decision), each with its own ``--set-a`` / ``--set-b`` scenario settings
(e.g. the same tree twice, ``--set-b trackers.kpf.fovea.use=decision``; ``--set-b
trackers.kpf.fovea=null``: the decision without the fovea).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
#: The rates a run reports (:func:`child`); ``wall``: the median over its repeats of the frames
#: per second of wall-clock time (counts work on other threads; meaningful only while the
#: machine has a core to spare).
STATS = ("median", "floor", "wall")


def _env(tree: str) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(Path(tree).resolve()), str(HERE)])
    env.setdefault("MUJOCO_GL", "egl")
    return env


def prepare(path: str, frames: int, gesture: str = "side") -> None:
    """Render the frames and the tracker's start (as ``bench_kpf``) into a pickle."""
    from bench_kpf import bench_frames

    data = bench_frames(frames, gesture)
    with open(path, "wb") as f:
        pickle.dump(data, f)


def prepare_fovea(path: str, frames: int, gesture: str = "side") -> None:
    """As :func:`prepare`, through ``schmidt_table1_fovgaze.yaml``'s two cameras (the left
    eye's wide and foveal), the eyes set on the TRUE right elbow every frame (a stand-in for
    the scenario's gaze on the tracker's estimate: the same work per frame)."""
    import mujoco

    from humimic import bodymodel as bm
    from humimic.paths import SCENARIOS_DIR
    from humimic.perception.trackers.common import skin_model_lut
    from humimic.rngs import Rngs
    from humimic.scenario import load_scenario
    from humimic.sensors.camera_model import invert_transform
    from humimic.world.world import World

    sc = load_scenario(SCENARIOS_DIR / "schmidt_table1_fovgaze.yaml",
                       [f"human.motion.gestures=[{gesture}]"], seed=0, duration=frames / 7.5)
    world = World(sc, Rngs(0))
    m, d = world.scene.model, world.scene.data
    out = []
    try:
        lut = skin_model_lut(sc, world, ["L_wide", "L_foveal"], "bench")
        elbow = world.gt.p_world("right_elbow")
        every = int(round(sc.timing.physics_rate / 7.5))
        for tick in range(0, world.n_ticks, every):
            world.apply_human(tick)
            mujoco.mj_forward(m, d)
            world.look_at_point(elbow[tick])
            shots = world.eye_rig.capture(tick / sc.timing.physics_rate)
            out.append([(shots[c].image, invert_transform(shots[c].camera.T_base_cam))
                        for c in ("L_wide", "L_foveal")])
        data = {"frames": [f[0] for f in out], "fovea": [f[1] for f in out],
                "intrinsics": shots["L_wide"].camera.intrinsics,
                "fovea_intrinsics": shots["L_foveal"].camera.intrinsics,
                "q0": bm.truth_state(world, 0, "base"), "lut": lut}
    finally:
        world.close()
    with open(path, "wb") as f:
        pickle.dump(data, f)


def child(path: str, config: tuple[int, int], name: str, repeats: int,
          fovea: bool = False, fovgaze: list[str] | None = None) -> None:
    """Track the pickled frames ``repeats`` times; print the thread-CPU rates (JSON).
    ``fovgaze``: the ``--set``s of ``schmidt_table1_fovgaze.yaml`` whose ``kpf`` runs (with
    its fovea)."""
    import cv2

    from humimic.paths import SCENARIOS_DIR
    from humimic.perception.trackers.kpf.frame_cues import FrameCues
    from humimic.perception.trackers.kpf.tracker import KpfTracker, kpf_body
    from humimic.perception.trackers.kpf.warmup import load_kernels
    from humimic.scenario import load_scenario

    cv2.setNumThreads(1)
    with open(path, "rb") as f:
        data = pickle.load(f)
    frames, intr, q0, lut = data["frames"], data["intrinsics"], data["q0"], data["lut"]
    n, it = config
    base = load_scenario(SCENARIOS_DIR / "schmidt_table1.yaml").trackers[name] \
        if fovgaze is None else load_scenario(SCENARIOS_DIR / "schmidt_table1_fovgaze.yaml",
                                              fovgaze).trackers["kpf"]
    fovea = fovea or (fovgaze is not None and base.fovea is not None)
    cfg = base.model_copy(update={"n_particles": n, "iterations": it})
    body = kpf_body()
    load_kernels(body, intr, cfg, frames[0][0], lut, frames[0][1], q0)
    kw = {"colour_gradients": cfg.colour_gradients}
    fov = data.get("fovea") if fovea else None
    if fov is not None:
        from humimic.perception.trackers.kpf.fovea import FovealLikelihood

        f = cfg.fovea if fovgaze is not None else load_scenario(
            SCENARIOS_DIR / "schmidt_table1_fovgaze.yaml").trackers["kpf"].fovea
        cfg = cfg.model_copy(update={"fovea": f})
    cpu, wall = [], []
    for _ in range(repeats):
        lik = None if fov is None else FovealLikelihood(
            body, intr, cfg, data["fovea_intrinsics"], tuple(f.parts), f.weight, f.use,
            f.decision_weight, f.moving_mm / 1000.0)
        tr = KpfTracker(body, intr, cfg, np.random.default_rng(0), lik=lik)
        if lik is not None:
            lik.look(FrameCues(fov[0][0], lut, **kw), fov[0][1])
        tr.start(q0, FrameCues(frames[0][0], lut, **kw), frames[0][1])
        cpu.append([])
        t0 = time.perf_counter()
        for i, (img, T) in enumerate(frames[1:], 1):
            c0 = time.thread_time()
            if lik is not None:
                lik.look(FrameCues(fov[i][0], lut, **kw), fov[i][1], tr.mode, None,
                         tr.mode_prev)
            tr.step(FrameCues(img, lut, **kw), T)
            cpu[-1].append(time.thread_time() - c0)
        wall.append(time.perf_counter() - t0)
    n_f = len(frames) - 1
    print(json.dumps({"median": statistics.median(n_f / np.sum(cpu, axis=1)),
                      "floor": n_f / float(np.min(cpu, axis=0).sum()),
                      "wall": statistics.median(n_f / np.array(wall))}))


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("trees", nargs="*", help="two source trees (directories holding humimic/)")
    p.add_argument("--rounds", type=int, default=10)
    p.add_argument("--config", default="150,2", metavar="P,I")
    p.add_argument("--only", default="kpf", help="tracker of schmidt_table1.yaml")
    p.add_argument("--frames", type=int, default=20)
    p.add_argument("--repeats", type=int, default=5, help="runs of the frames per round")
    p.add_argument("--gesture", default="side", choices=("side", "angle"),
                   help="the pointing gesture of the frames")
    p.add_argument("--fovea", action="store_true",
                   help="frames of schmidt_table1_fovgaze.yaml (the eye on the true elbow); "
                   "tree B's runs with its trackers.kpf.fovea, tree A's without")
    p.add_argument("--fovgaze", action="store_true",
                   help="frames as --fovea; both trees' runs with schmidt_table1_fovgaze.yaml's "
                   "kpf (fovea and flip-branch decision) and their --set-a / --set-b")
    p.add_argument("--set-a", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--set-b", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--fovgaze-child", nargs="*", help=argparse.SUPPRESS)
    p.add_argument("--fovea-child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--prepare", help=argparse.SUPPRESS)
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args()
    config = tuple(int(x) for x in args.config.split(","))
    if args.prepare:
        return (prepare_fovea if args.fovea else prepare)(args.prepare, args.frames,
                                                         args.gesture)
    if args.child:
        return child(args.child, config, args.only, args.repeats, args.fovea_child,
                     args.fovgaze_child)
    if len(args.trees) != 2:
        p.error("give two source trees")
    me = [sys.executable, str(Path(__file__).resolve())]
    with tempfile.TemporaryDirectory() as tmp:
        data = str(Path(tmp) / "frames.pkl")
        subprocess.run(me + ["--prepare", data, "--frames", str(args.frames), "--gesture",
                            args.gesture] + (["--fovea"] if args.fovea or args.fovgaze else []),
                       check=True,
                       env=_env(args.trees[0]))
        hz = {s: {0: [], 1: []} for s in STATS}
        for r in range(args.rounds):
            for k in ((0, 1) if r % 2 == 0 else (1, 0)):
                fov = ["--fovea-child"] if args.fovea and k == 1 else []
                if args.fovgaze:
                    fov = ["--fovgaze-child", *(args.set_a, args.set_b)[k]]
                out = subprocess.run(me + ["--child", data, "--config", args.config, "--only",
                                           args.only, "--repeats", str(args.repeats)] + fov,
                                     check=True, env=_env(args.trees[k]), capture_output=True,
                                     text=True).stdout
                got = json.loads(out.strip().splitlines()[-1])
                for s in STATS:
                    hz[s][k].append(got[s])
            print(f"round {r + 1:3d}: " + "  ".join(
                f"{s} A {hz[s][0][-1]:6.1f} B {hz[s][1][-1]:6.1f} Hz" for s in STATS),
                flush=True)
    print(f"{args.only} at {config}, {args.rounds} rounds x {args.repeats} runs, frames per "
          "second of thread CPU time (median: of a run's total; floor: of each frame's least "
          "time over a round's runs) and of wall-clock time (wall: of a run's total):")
    for s in STATS:
        for k, tree in enumerate(args.trees):
            q1, q3 = np.percentile(hz[s][k], [25, 75])
            print(f"  {s:6s} {'AB'[k]} {tree}: {statistics.median(hz[s][k]):.1f} Hz "
                  f"(rounds' q1-q3 {q1:.1f}-{q3:.1f})")
        ratios = np.array(hz[s][1]) / np.array(hz[s][0])
        q1, q3 = np.percentile(ratios, [25, 75])
        print(f"  {s:6s} B / A: {statistics.median(hz[s][1]) / statistics.median(hz[s][0]):.3f}"
              f" (of the medians), per round {statistics.median(ratios):.3f} "
              f"(q1-q3 {q1:.3f}-{q3:.3f})")


if __name__ == "__main__":
    main()
