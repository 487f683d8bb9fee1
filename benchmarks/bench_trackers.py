"""Speed of Menezes' 3-D trackers per frame, rendering excluded (issue 13's goals: GEST >= 250
fps at N = 100, TBP >= 20 fps at N = 400, on this 2-core machine).

Run: ``python benchmarks/bench_trackers.py [--frames 30] [--repeats 3] [--only gest-far]``.
Renders the frames of ``menezes_gest_reach`` (stereo), ``menezes_gest_far`` (both eyes' wide
and foveal cameras, the eyes on the hand) and ``fig12_tbp_pointing`` (left eye) once, then
times the trackers' ``step`` over them (GEST on the far frames in the foveal pair with its cue
images at full resolution and within ``foveal_cue_radius_px``, and in the wide pair; GEST
after an untimed warm-up run, which compiles or loads its numba kernels; median and
interquartile range over repeats of the whole sequence, each from a fresh tracker), and the
per-frame image preparation alone. ``--clock cpu`` (default) is ``time.process_time``, every
thread of this process: on a shared machine the wall clock mostly measures the other sessions,
but on a quiet one OpenCV's idle workers make CPU time exceed the wall; ``--clock wall`` is
what a user of a quiet machine sees.
"""

# ruff: noqa: I001  -- humimic must be imported before mujoco (headless GL)
from __future__ import annotations

import argparse
import os
import time

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import mujoco
import numpy as np

from humimic.bodymodel.avatar import truth_hand_state, truth_state
from humimic.paths import SCENARIOS_DIR
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.world.world import World

GOALS_FPS = {"gest": 250.0, "tbp": 20.0}


def render(name: str, n: int, cams: int, gaze: bool = False):
    """The first ``n`` frames of scenario ``name`` from its first ``cams`` eye cameras; with
    ``gaze`` the eyes turned to the person's right hand in every frame (as the active gaze
    keeps it in the foveal pair)."""
    sc = load_scenario(SCENARIOS_DIR / name, duration=n / 30 + 0.2)
    rngs = Rngs(sc.seed)
    world = World(sc, rngs)
    frames = []
    for k in range(n):
        t = k / 30
        tick = world.gt.index_of(t)
        world.apply_human(tick)
        mujoco.mj_forward(world.scene.model, world.scene.data)
        if gaze:
            world._look_at(truth_hand_state(world, tick, "R", np.eye(4))[:3])
        imgs = world.eye_rig.capture(t)
        frames.append((t, tick, [imgs[c] for c in world.eye_cameras[:cams]]))
    return sc, world, rngs, frames


CLOCK = {"cpu": time.process_time, "wall": time.perf_counter}
clock = CLOCK["cpu"]


def time_runs(make, run, repeats: int, warmup: bool = False) -> list[float]:
    """Seconds per frame of ``repeats`` runs, each on a fresh ``make(r)``; ``warmup``: one
    untimed run first (numba's kernels compile, or load from their disk cache, on first
    use)."""
    if warmup:
        run(make(-1))
    out = []
    for r in range(repeats):
        tracker = make(r)
        t0 = clock()
        n = run(tracker)
        out.append((clock() - t0) / n)
    return out


def report(name: str, secs: list[float], goal: float | None = None) -> None:
    q = np.percentile(secs, [25, 50, 75])
    fps = 1.0 / q[1]
    verdict = ("" if goal is None
               else f"  goal {goal:.0f} fps: {'met' if fps >= goal else 'NOT met'}")
    print(f"{name:28s} {1e3 * q[1]:7.2f} ms/frame (q1-q3 {1e3 * q[0]:.2f}-{1e3 * q[2]:.2f})"
          f"  {fps:6.1f} fps{verdict}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--clock", choices=tuple(CLOCK), default="cpu",
                    help="cpu: this process's CPU time, every thread (OpenCV's idle workers "
                         "spin, so a quiet machine shows more than the wall); wall: "
                         "perf_counter, meaningful only on a quiet machine")
    ap.add_argument("--cv-threads", type=int, default=None,
                    help="cv2.setNumThreads before timing (default: OpenCV's own, one worker "
                         "per core; on these small images 1 is faster and spins no workers)")
    ap.add_argument("--only", nargs="+", choices=("gest", "gest-far", "tbp"),
                    help="time only these (default all): GEST on menezes_gest_reach, on "
                         "menezes_gest_far (foveal and wide pairs), TBP")
    args = ap.parse_args()
    global clock
    clock = CLOCK[args.clock]
    if args.cv_threads is not None:
        import cv2

        cv2.setNumThreads(args.cv_threads)

    sections = {"gest": wide_gest, "gest-far": foveal_gest, "tbp": tbp}
    for name in args.only or tuple(sections):
        sections[name](args)
    import cv2

    print(f"({args.clock} time; quartiles over {args.repeats} runs of {args.frames} frames each; "
          f"OpenCV threads {cv2.getNumThreads()}; load average {os.getloadavg()[0]:.1f})")


def wide_gest(args) -> None:
    """GEST on ``menezes_gest_reach`` (the wide pair)."""
    from humimic.perception.cues.importance import skin_blobs
    from humimic.perception.trackers.gest.build import gest_stage

    sc, world, rngs, frames = render("menezes_gest_reach.yaml", args.frames, 2)
    cfg = sc.trackers["gest"]
    stage = gest_stage("gest", cfg, sc, world, rngs, None)

    def gest_run(trk):
        for _, _, (left, right) in frames:
            trk.step(left, right, np.random.default_rng(0))
        return len(frames)

    from humimic.perception.trackers.gest.tracker import GestTracker

    report(f"gest N={cfg.n_particles}", time_runs(lambda r: GestTracker(cfg, stage.tracker.lut),
                                        gest_run, args.repeats, warmup=True), GOALS_FPS["gest"])
    report("  gest skin blobs, whole frames", time_runs(
        lambda r: None, lambda _: [skin_blobs((stage.tracker.lut.posterior(f.image) > 0.5)
                                              .astype(np.uint8), subsample=cfg.blob_subsample)
                                   for _, _, fs in frames for f in fs] and len(frames),
        args.repeats))
    world.eye_rig.close()


def tbp(args) -> None:
    """TBP on ``fig12_tbp_pointing`` (left eye)."""
    from humimic.perception.trackers.tbp.build import tbp_stage
    from humimic.perception.trackers.tbp.likelihood import arm_view
    from humimic.perception.trackers.tbp.tracker import TbpTracker

    sc, world, rngs, frames = render("fig12_tbp_pointing.yaml", args.frames, 1)
    cfg = sc.trackers["tbp"].model_copy(update={"torso": "truth"})
    stage = tbp_stage("tbp", sc.trackers["tbp"], sc, world, rngs, None)
    torsos = [truth_state(world, tick, "base")[:6] for _, tick, _ in frames]

    def tbp_run(trk):
        for (_, _, (f,)), torso in zip(frames, torsos, strict=True):
            trk.step(f, torso, np.random.default_rng(0))
        return len(frames)

    report(f"tbp N={cfg.n_particles}", time_runs(
        lambda r: TbpTracker(cfg, stage.tracker.body, stage.tracker.lut), tbp_run,
        args.repeats), GOALS_FPS["tbp"])
    report("  tbp image prep (flow, edges)", time_runs(
        lambda r: TbpTracker(cfg, stage.tracker.body, stage.tracker.lut),
        lambda trk: [arm_view(f, None, trk.lut, 32) for _, _, (f,) in frames] and len(frames),
        args.repeats))
    world.eye_rig.close()


def foveal_gest(args) -> None:
    """GEST on ``menezes_gest_far`` (hand 1.2-1.6 m away) with the eyes on the hand: in the
    foveal pair (its cue images at full resolution and within ``foveal_cue_radius_px``) and, on
    the same frames, in the wide pair."""
    from humimic.perception.trackers.gest.build import gest_stage
    from humimic.perception.trackers.gest.foveal import choose_pair
    from humimic.perception.trackers.gest.tracker import GestTracker

    sc, world, rngs, frames = render("menezes_gest_far.yaml", args.frames, 4, gaze=True)
    cfg = sc.trackers["gest"]
    lut = gest_stage("gest", cfg, sc, world, rngs, None).tracker.lut
    used = []

    def run(foveal: bool):
        def go(trk):
            for _, _, (lw, rw, lf, rf) in frames:
                left, right = choose_pair((lw, rw), (lf, rf) if foveal else None, trk.last,
                                          cfg.foveal_margin_px)
                used.append(left is lf)
                trk.step(left, right, np.random.default_rng(0),
                         silhouette_offset=cfg.foveal_offset or left is lw,
                         foveal=left is lf)
            return len(frames)
        return go

    budget = cfg.foveal_cue_radius_px or 12.0
    configs = (("gest far, wide pair", cfg, False),
               ("gest far, foveal, full res",
                cfg.model_copy(update={"foveal_cue_radius_px": None}), True),
               (f"gest far, foveal, r<={budget:g}px",
                cfg.model_copy(update={"foveal_cue_radius_px": budget}), True))
    secs: dict[str, list[float]] = {label: [] for label, _, _ in configs}
    share = {}
    for _, c, foveal in configs:        # warm-up, untimed (compiled kernels' first use)
        run(foveal)(GestTracker(c, lut))
    for _ in range(args.repeats):       # interleaved: a change of load hits each one alike
        for label, c, foveal in configs:
            used.clear()
            secs[label] += time_runs(lambda r, c=c: GestTracker(c, lut), run(foveal), 1)
            share[label] = np.mean(used)
    for label, _, foveal in configs:
        report(label, secs[label], GOALS_FPS["gest"])
        if foveal:
            print(f"{'':28s} {share[label]:.0%} of the frames in the foveal pair")
    ratio = np.array(secs[configs[2][0]]) / np.array(secs[configs[1][0]])
    q = np.percentile(ratio, [25, 50, 75])
    print(f"{'':28s} r<={budget:g}px / full res, same repeat: {q[1]:.2f} (q1-q3 "
          f"{q[0]:.2f}-{q[2]:.2f})")
    world.eye_rig.close()


if __name__ == "__main__":
    main()
