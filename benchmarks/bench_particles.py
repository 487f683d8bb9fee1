"""Per-frame cost of the particle-filter library, Menezes' image cues, face detection and
recognition at 320 x 240 -- the parts the 2-D hand tracker (goal >= 500 fps, CONDENSATION,
N = 100) and the ICU tracker (goal >= 200 fps, ICONDENSATION, N = 150, detection and
recognition every frame) will be built from.

Run from the project root::

    .venv/bin/python benchmarks/bench_particles.py [--repeats 7] [--quick]

Frames: the avatar rendered by the foveal eye camera at 3 m and the wide one at 1 m (a face of
~38 / ~21 px), plus the next frame with the person moved 3 cm for the optical flow. Timings
exclude rendering. The two "tracker frame" rows add up what one frame of each tracker will
run (their other costs -- bookkeeping, the bus -- come on top).
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import numpy as np
from rich.console import Console

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _harness import Row, per_call, row  # noqa: E402
from run_all import print_table  # noqa: E402

from humimic.estimation.particles import (  # noqa: E402
    GaussianMixture,
    RandomWalk,
    Resetting,
    UniformBox,
    condensation_step,
    icondensation_step,
    apf_step,
    resample_indices,
)
from humimic.perception.cues.edges import dt_distance, edge_maps, normal_edge_distance  # noqa: E402
from humimic.perception.cues.histograms import (  # noqa: E402
    HEAD_TORSO_PATCHES,
    color_log_likelihood,
    patch_histograms,
    quantize,
)
from humimic.perception.cues.motion import (  # noqa: E402
    OpticalFlow,
    motion_dt_distance,
    motion_edge_maps,
    motion_normal_distance,
)
from humimic.perception.cues.templates import hand, head_and_shoulders  # noqa: E402
from humimic.perception.faces.detect import DetectorParams, FaceDetector, crop_faces  # noqa: E402
from humimic.perception.faces.eigenfaces import train  # noqa: E402
from humimic.perception.faces.studio import FaceStudio, FaceView  # noqa: E402

G = "particles"


def frames() -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """camera -> (previous frame, frame, true head (u, v, size px))."""
    out = {}
    for cam, dist in (("foveal", 3.0), ("wide", 1.0)):
        with FaceStudio("ada", f"L_{cam}") as s:
            a = s.render(FaceView(distance=dist, lateral=0.03, aim_offset=(0.03, 0.0)))
            b = s.render(FaceView(distance=dist, lateral=0.0, aim_offset=(0.0, 0.0)))
        out[cam] = (a.image, b.image, np.array([*b.center_px, b.size_px]))
    return out


def states(n: int, head: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return head + rng.normal(0.0, [6.0, 6.0, 1.0], (n, 3))


def bench(repeats: int) -> list[Row]:
    rng = np.random.default_rng(0)
    fr = frames()
    prev, img, head = fr["foveal"]
    rows: list[Row] = []
    inner = 50

    # ---- resampling and filter steps (likelihood: a cheap closed form) ---------------------
    for n in (100, 150, 400):
        lw = np.log(rng.random(n))
        for method in ("systematic", "stratified", "residual", "multinomial"):
            rows.append(row(G, f"resample {method}, N={n}", per_call(
                lambda lw=lw, m=method: resample_indices(lw, rng, m), repeats, inner),
                "us", 1e6))
    box = UniformBox([0, 0, 5], [320, 240, 80])
    dyn3 = Resetting(RandomWalk([11.0, 6.0, np.sqrt(0.1)]), box, 0.01)
    target = head
    ll3 = lambda x: -0.5 * np.sum(((x - target) / [4, 4, 2]) ** 2, axis=1)  # noqa: E731
    x100, x150, x400 = (states(n, head, rng) for n in (100, 150, 400))
    lw_u = {n: np.full(n, -np.log(n)) for n in (100, 150, 400)}
    pi = GaussianMixture(np.array([head, head + [40, 5, 0]]), [6.0, 6.0, 2.0])
    rows.append(row(G, "CONDENSATION step, N=100 (cheap likelihood)", per_call(
        lambda: condensation_step(x100, lw_u[100], dyn3, ll3, rng), repeats, inner), "us", 1e6))
    rows.append(row(G, "ICONDENSATION step, N=150 (cheap likelihood)", per_call(
        lambda: icondensation_step(x150, lw_u[150], dyn3, ll3, rng, pi, box), repeats, inner),
        "us", 1e6, note="incl. the N x N predictive density of the mixture weights"))
    rows.append(row(G, "APF step, N=400 (cheap likelihood)", per_call(
        lambda: apf_step(x400, lw_u[400], dyn3, ll3, rng), repeats, inner), "us", 1e6))

    # ---- per-frame image work (independent of N) -------------------------------------------
    flow = OpticalFlow()
    maps = edge_maps(img)
    f = flow(prev, img)
    mmaps = motion_edge_maps(maps, f)
    q = quantize(img)
    rows.append(row(G, "Canny + distance transform 320x240", per_call(
        lambda: edge_maps(img), repeats, 20), "ms", 1e3))
    rows.append(row(G, "optical flow (DIS ultrafast) 320x240", per_call(
        lambda: flow(prev, img), repeats, 20), "ms", 1e3))
    rows.append(row(G, "moving edges + their distance transform", per_call(
        lambda: motion_edge_maps(maps, f), repeats, 20), "ms", 1e3))
    rows.append(row(G, "quantise RGB to 32 bins", per_call(lambda: quantize(img), repeats, 20),
                    "ms", 1e3))

    # ---- likelihoods for all particles -----------------------------------------------------
    hs15, hs_hand = head_and_shoulders(15), hand(30)
    refs = patch_histograms(q, head[None], HEAD_TORSO_PATCHES)[0]
    for n, x in ((100, x100), (150, x150), (400, x400)):
        p15, _ = hs15.place(x)
        p30, n30 = hs_hand.place(x)
        rows.append(row(G, f"shape DT eq.3, Np=15, N={n}", per_call(
            lambda p=p15: dt_distance(maps.dt, p), repeats, inner), "us", 1e6))
        rows.append(row(G, f"shape normal search eq.2, Np=30, N={n}", per_call(
            lambda p=p30, nn=n30: normal_edge_distance(maps.edges, p, nn, 15), repeats, inner),
            "us", 1e6))
        rows.append(row(G, f"shape+motion DT eq.5, Np=30, N={n}", per_call(
            lambda p=p30: motion_dt_distance(mmaps, p, 0.5), repeats, inner), "us", 1e6))
        rows.append(row(G, f"shape+motion normal eq.4, Np=30, N={n}", per_call(
            lambda p=p30, nn=n30: motion_normal_distance(mmaps, p, nn, 0.12, 15), repeats,
            inner), "us", 1e6))
        rows.append(row(G, f"colour 2 patches eq.6, 8x8 grid, N={n}", per_call(
            lambda x=x: color_log_likelihood(patch_histograms(q, x, HEAD_TORSO_PATCHES), refs,
                                             0.03), repeats, inner), "us", 1e6))
        rows.append(row(G, f"place templates (Np=15 and 30), N={n}", per_call(
            lambda x=x: (hs15.place(x), hs_hand.place(x)), repeats, inner), "us", 1e6))

    # ---- faces -----------------------------------------------------------------------------
    det = FaceDetector()
    for cam in ("foveal", "wide"):
        rows.append(row(G, f"Haar frontal face, 320x240 ({cam} frame)", per_call(
            lambda im=fr[cam][1]: det.detect(im), repeats, 10), "ms", 1e3,
            note="haarcascade_frontalface_default, scale 1.1, 2 neighbours, 20 px and up"))
    for label, p in (("faces 20-80 px", DetectorParams(max_size=80)),
                     ("scale step 1.2", DetectorParams(scale_factor=1.2))):
        d = FaceDetector(p)
        rows.append(row(G, f"Haar frontal face, 320x240, {label}", per_call(
            lambda d=d: d.detect(img), repeats, 10), "ms", 1e3))
    boxes = det.detect(img)
    if len(boxes) == 0:
        boxes = np.array([[head[0] - 19, head[1] - 19, 38, 38]])
    # random crops with as many eigenvectors per class as the rendered faces' model (17-23)
    model = train({f"c{i}": rng.integers(0, 256, (60, 30, 30), dtype=np.uint8)
                   for i in range(10)}, variance=0.95, max_components=20)
    for k in (1, 3):
        b = np.repeat(boxes[:1], k, axis=0)
        rows.append(row(G, f"recognise {k} face(s): crop + equalise + 10 DFFS", per_call(
            lambda b=b: model.probabilities(crop_faces(img, b)), repeats, inner), "us", 1e6,
            note=f"{sum(len(x) for x in model.bases)} eigenvectors over 10 classes"))

    # ---- one frame of each tracker ---------------------------------------------------------
    dyn4 = RandomWalk([5.0, 5.0, 0.5, 0.05])
    x4 = np.column_stack([x100, np.zeros(100)])
    lw100 = lw_u[100]

    def hand2d_frame():
        m = motion_edge_maps(edge_maps(img), flow(prev, img))
        ll = lambda x: -motion_dt_distance(m, hs_hand.place(x)[0], 0.5) ** 2 / (  # noqa: E731
            2 * 1.2**2)
        return condensation_step(x4, lw100, dyn4, ll, rng)

    def icu_frame():
        faces = det.detect(img)
        probs = model.probabilities(crop_faces(img, faces))[:, 0] if len(faces) else []
        m = edge_maps(img)
        qq = quantize(img)
        c = faces[:, :2] + faces[:, 2:] / 2 if len(faces) else np.zeros((0, 2))
        prop = GaussianMixture(np.column_stack([c, faces[:, 2:3]]) if len(faces) else
                               np.zeros((0, 3)), [6.0, 6.0, 2.0], np.asarray(probs) + 1e-3)

        def ll(x):
            d = dt_distance(m.dt, hs15.place(x)[0])
            return -d**2 / (2 * 1.5**2) + color_log_likelihood(
                patch_histograms(qq, x, HEAD_TORSO_PATCHES), refs, 0.03)
        return icondensation_step(x150, lw_u[150], dyn3, ll, rng, prop, box)

    rows.append(row(G, "hand2d frame: edges, flow, eq.5 N=100 Np=30, CONDENSATION", per_call(
        hand2d_frame, repeats, 10), "ms", 1e3, note="goal >= 500 fps (2 ms)"))
    rows.append(row(G, "ICU frame: Haar, recognition, edges, DT+colour N=150, ICONDENSATION",
                    per_call(icu_frame, repeats, 10), "ms", 1e3, note="goal >= 200 fps (5 ms)"))
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="3 repeats")
    args = ap.parse_args(argv)
    rows = bench(3 if args.quick else args.repeats)
    print_table(Console(), rows, [], "particle filters, cues, faces: per-frame cost")
    return 0


if __name__ == "__main__":
    sys.exit(main())
