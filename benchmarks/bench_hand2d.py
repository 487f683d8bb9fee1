"""Per-frame cost of the 2-D hand tracker (Menezes sec. 5.1; goal >= 500 fps at 320 x 240,
excluding rendering) on the Fig. 5 scenario's frames, whole and by part.

Run from the project root::

    .venv/bin/python benchmarks/bench_hand2d.py [--repeats 7] [--quick] [--clock cpu]

Frames: ``scenarios/menezes_fig5_hand.yaml`` (left foveal camera, cluttered wall, the hand
~35 px wide) rendered once for 2 s at 60 Hz. "tracking frame" replays the sequence through a
tracker that is tracking (detection frames -- skin blobs, template, the face check -- are
timed apart: they run only until the hand is found and after a loss).
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import sys
import time
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _harness import Row, per_call, row  # noqa: E402
from run_all import tracker_main  # noqa: E402

from humimic.paths import SCENARIOS_DIR  # noqa: E402
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL  # noqa: E402
from humimic.perception.cues.color_models import ColorLUT, load_color_model  # noqa: E402
from humimic.perception.cues.edges import canny, colour_canny, grey  # noqa: E402
from humimic.perception.cues.motion import OpticalFlow  # noqa: E402
from humimic.perception.faces.detect import FaceDetector  # noqa: E402
from humimic.perception.trackers.hand2d.likelihood import (  # noqa: E402
    frame_cues,
    log_likelihood,
    roi_of,
)
from humimic.perception.trackers.hand2d.tracker import Hand2DTracker  # noqa: E402
from humimic.perception.trackers.hand2d.warmup import load_kernels  # noqa: E402
from humimic.rngs import Rngs  # noqa: E402
from humimic.scenario import load_scenario  # noqa: E402
from humimic.world.world import World  # noqa: E402

G = "hand2d"


def render(seconds: float = 2.0, scenario: str = "menezes_fig5_hand.yaml",
           tracker: str = "hand", camera: str = "L_foveal") -> tuple[list[np.ndarray], object]:
    """A scenario's frames of one camera at 60 Hz for ``seconds``, and a tracker's config."""
    sc = load_scenario(SCENARIOS_DIR / scenario)
    world = World(sc, Rngs(sc.seed))
    try:
        world.eye_rig.prepare()
        frames = []
        for tick in range(0, int(seconds * 840), 14):
            world.apply_human(tick)
            mujoco.mj_forward(world.scene.model, world.scene.data)
            frames.append(world.eye_rig.capture(tick / 840.0)[camera].image)
    finally:
        world.close()
    return frames, sc.trackers[tracker]


def tracking_steps(tracker, frames, repeats: int, clock: str) -> tuple[list, list]:
    """Per repeat (the frames forwards, then backwards: no jump), the mean time of a step that
    starts and ends tracking, and the mean over every step (a loss's re-detection frames, ~8
    ms each, included: how often they come depends on the clutter and on the reversal)."""
    now = time.perf_counter if clock == "wall" else time.process_time
    seq = frames + frames[-2:0:-1]
    tracker.step(frames[0])
    tracking, every = [], []
    for _ in range(repeats):
        kept, total = [], 0.0
        for f in seq:
            before = tracker.state
            t0 = now()
            tracker.step(f)
            dt = now() - t0
            total += dt
            if before == "tracking" and tracker.state == "tracking":
                kept.append(dt)
        tracking.append(float(np.mean(kept)) if kept else float("nan"))
        every.append(total / len(seq))
    return tracking, every


def bench(repeats: int, clock: str = "wall") -> list[Row]:
    frames, base = render()
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))
    rows = []
    for label, cues in (("shape+motion+skin (default)", ["shape", "motion", "skin"]),
                        ("shape+motion (eq. 4)", ["shape", "motion"]),
                        ("all fused", ["shape", "motion", "colour", "skin"]),
                        ("shape+motion (eq. 5, dt)", ["shape", "motion"])):
        cfg = base.model_copy(update={"cues": tuple(cues)})
        if "dt" in label:
            cfg = cfg.model_copy(update={"similarity": "dt"})
        tracker = Hand2DTracker(cfg, lut, 320, 240, np.random.default_rng(0), FaceDetector())
        load_kernels(cfg, lut)      # as the stage: numba's kernels loaded outside the timing
        tracking, every = tracking_steps(tracker, frames, repeats, clock)
        rows.append(row(G, f"tracking frame, {label}, N={cfg.n_particles}", tracking, "ms",
                        1e3, note="goal >= 500 fps (2 ms)"))
        rows.append(row(G, f"  every frame incl. re-detections, {label}", every, "ms", 1e3))
    # parts, at the tracker's state on the middle frame
    cfg = base
    tracker = Hand2DTracker(cfg, lut, 320, 240, np.random.default_rng(0), FaceDetector())
    for f in frames[:31]:
        tracker.step(f)
    img, prev = frames[31], grey(frames[30])
    g = grey(img)
    pts, _ = tracker.template.place(tracker.pf.particles)
    roi = roi_of(pts, cfg.roi_margin_px + cfg.search_px + 18, 320, 240)
    x0, y0, x1, y1 = roi
    gr, pr = np.ascontiguousarray(g[y0:y1, x0:x1]), np.ascontiguousarray(prev[y0:y1, x0:x1])
    flow = OpticalFlow()
    fl = flow(pr, gr)
    # the edges' input as the tracker gives it: the colour ROI (edges: colour) or the grey one
    er = gr if cfg.edges == "grey" else np.ascontiguousarray(img[y0:y1, x0:x1])
    cues = frame_cues(er, fl, (x0, y0), tracker.params, cfg.min_flow_px, None)
    x = tracker.pf.particles
    size = f"ROI {x1 - x0}x{y1 - y0}"
    for name, fn in ((f"Canny, {size}", lambda: canny(gr)),
                     (f"Canny on the colour gradient, {size}", lambda: colour_canny(er)),
                     (f"optical flow (DIS), {size}", lambda: flow(pr, gr)),
                     (f"cue maps (edges + moving edges), {size}",
                      lambda: frame_cues(er, fl, (x0, y0), tracker.params, 0.5, None)),
                     ("likelihood eq. 4, N=100, Np=30",
                      lambda: log_likelihood(cues, x, tracker.template, tracker.params, None)),
                     ("skin mask, whole image (detection frames)", lambda: lut.posterior(img)),
                     ("detection frame (search)", lambda: _search(tracker, img, g))):
        rows.append(row(G, name, per_call(fn, repeats, 20, clock=clock), "us", 1e6))
    return rows


def _search(tracker, img, g):
    tracker.state = "lost"
    tracker._search(img, g)


def main(argv: list[str] | None = None) -> int:
    return tracker_main(bench, "hand2d tracker: per-frame cost (no rendering)", __doc__, argv)


if __name__ == "__main__":
    sys.exit(main())
