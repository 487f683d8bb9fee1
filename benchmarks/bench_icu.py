"""Per-frame cost of the ICU tracker (Menezes sec. 5.2; goal >= 200 fps at 320 x 240 with
detection and recognition every frame, excluding rendering), whole and by part: Haar in the
window around the estimate, around the skin blobs and on the whole frame, the skin mask,
recognition, edges, likelihood, ICONDENSATION (with its resampling).

Run from the project root::

    .venv/bin/python benchmarks/bench_icu.py [--repeats 7] [--quick] [--clock cpu]

Frames: the first 2 s of ``scenarios/menezes_fig10_crossing.yaml`` (left foveal camera, the
tutor's face ~47 px at 2.5 m, the other person walking in).
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import sys
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _harness import Row, per_call, row  # noqa: E402
from bench_hand2d import render  # noqa: E402
from run_all import tracker_main  # noqa: E402

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL  # noqa: E402
from humimic.perception.cues.color_models import ColorLUT, load_color_model  # noqa: E402
from humimic.perception.cues.edges import edge_maps, grey  # noqa: E402
from humimic.perception.cues.histograms import quantize  # noqa: E402
from humimic.perception.cues.importance import skin_blobs  # noqa: E402
from humimic.perception.faces.detect import DetectorParams, FaceDetector, crop_faces  # noqa: E402
from humimic.perception.faces.training import RenderSpec, trained_model  # noqa: E402
from humimic.perception.trackers.icu.likelihood import log_likelihood  # noqa: E402
from humimic.perception.trackers.icu.tracker import (  # noqa: E402
    FACE_TO_HEAD,
    SKIN_POSTERIOR,
    WINDOW_SIZES,
    IcuTracker,
)
from humimic.world.faces import IDENTITY_NAMES  # noqa: E402

G = "icu"


def bench(repeats: int, clock: str = "wall") -> list[Row]:
    frames, cfg = render(2.0, "menezes_fig10_crossing.yaml", "icu")
    known = list(dict.fromkeys(["ben", "cyd", *IDENTITY_NAMES]))[: cfg.enrolled]
    model = trained_model(known, RenderSpec(per_identity=cfg.views),
                          DetectorParams(min_size=cfg.min_face_px))
    params = DetectorParams(min_size=cfg.min_face_px, scale_factor=cfg.face_scale_factor,
                            fit_px=cfg.face_fit_px)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))
    rows = []
    for label, every in (("face window every frame", 1), ("face window every 3rd frame", 3)):
        c = cfg.model_copy(update={"detect_every": every})
        tracker = IcuTracker(c, 320, 240, np.random.default_rng(0), FaceDetector(params),
                             model, 0, lut)
        tracker.step(frames[0])
        k = iter(range(10**9))

        def frame(tracker=tracker, k=k):
            i = next(k) % (2 * len(frames) - 2)
            tracker.step(frames[i if i < len(frames) else 2 * len(frames) - 2 - i])

        rows.append(row(G, f"tracking frame, {label}, N={c.n_particles}",
                        per_call(frame, repeats, len(frames), clock=clock), "ms", 1e3,
                        note="goal >= 200 fps (5 ms), detection + recognition every frame"))
    tracker = IcuTracker(cfg, 320, 240, np.random.default_rng(0), FaceDetector(params),
                         model, 0, lut)
    for f in frames[:30]:
        tracker.step(f)
    img = frames[30]
    g, q = grey(img), quantize(img, cfg.bins)
    rows.append(row(G, "searching frame (nobody tracked): skin blobs + Haar around them + "
                    "recognition", per_call(lambda: tracker.search_faces(img, g), repeats, 10,
                                            clock=clock), "ms", 1e3,
                    note="goal >= 200 fps (5 ms); the whole frame instead: see Haar, whole"))
    window = tracker._window(tracker.pf.mean)
    s = tracker.pf.mean[2]
    sizes = (WINDOW_SIZES[0] * s / FACE_TO_HEAD, WINDOW_SIZES[1] * s / FACE_TO_HEAD)
    boxes = tracker.detector.detect(g)
    dt, origin = tracker.shape_maps(g, boxes)
    x = tracker.pf.particles
    size = f"{window[2] - window[0]}x{window[3] - window[1]}"
    parts = (("Haar, whole frame (search: whole)", lambda: tracker.detector.detect(g)),
             ("skin mask (half resolution) + blobs", lambda: skin_blobs(
                 lut.posterior(img[::2, ::2]) > SKIN_POSTERIOR, 1)),
             (f"Haar, window {size}, faces {sizes[0]:.0f}-{sizes[1]:.0f} px",
              lambda: tracker.detect(g, window, sizes)),
             ("recognition of 1 face (crop, equalise, DFFS)",
              lambda: model.probabilities(crop_faces(g, boxes[:1]))),
             ("Canny + distance transform, whole frame (exact)", lambda: edge_maps(g)),
             (f"Canny + distance transform around the cloud ({dt.shape[1]}x{dt.shape[0]}, "
              "chamfer)", lambda: tracker.shape_maps(g, boxes)),
             ("quantise RGB (32 bins)", lambda: quantize(img, cfg.bins)),
             ("likelihood eq. 3 + eq. 6, N=150",
              lambda: log_likelihood(dt, q, x, tracker.template, tracker.refs, cfg.sigma_s,
                                     cfg.sigma_c, cfg.cues, origin)),
             ("ICONDENSATION step incl. resampling, N=150 (cheap likelihood)",
              lambda: tracker.pf.step(lambda s: np.zeros(len(s)), tracker.rng)))
    for name, fn in parts:
        rows.append(row(G, name, per_call(fn, repeats, 10, clock=clock), "us", 1e6))
    return rows


def main(argv: list[str] | None = None) -> int:
    return tracker_main(bench, "ICU tracker: per-frame cost (no rendering)", __doc__, argv)


if __name__ == "__main__":
    sys.exit(main())
