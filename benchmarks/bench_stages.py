"""Per-stage costs: EM blob tracker, stereo ZNCC + triangulation, Kalman step, IK solve, and the
closed loop's real-time factor. Each function returns :class:`Row`s (skipped rows, with a note,
when the stage is not there yet). Physics and rendering are in ``bench_world.py``.

Run them all with ``python benchmarks/run_all.py``.
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import numpy as np

from _harness import Row, per_call, row, skipped

ROOT = Path(__file__).resolve().parent.parent
SKIN_MODEL = ROOT / "models" / "colors" / "skin.json"
#: Per-axis std of a measured blob centre (px), as ``perception.pixel_std``.
PIXEL_STD = 0.3


def skin_lut():
    """The shipped skin colour model as a look-up table, or a model fitted to a skin patch."""
    from humimic.perception.cues.color_models import ColorLUT, fit_color_model, load_color_model

    if SKIN_MODEL.is_file():
        return ColorLUT(load_color_model(SKIN_MODEL)), "models/colors/skin.json"
    sys.path.insert(0, str(ROOT / "tests"))
    from _synth_vision import SKIN_RGB, add_noise

    rng = np.random.default_rng(1)
    patch = add_noise(np.full((60, 60, 3), SKIN_RGB, np.uint8), rng, 4.0)
    return ColorLUT(fit_color_model(patch.reshape(-1, 3), "rgb", 1, rng)), "fitted skin patch"


def synthetic_blob_frames(n: int = 120):
    """320x240 frames of 4 skin ellipses moving over a textured wall (tests/_synth_vision)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from _synth_vision import TexturedPlane, add_noise, draw_ellipse, stereo_head

    rng = np.random.default_rng(0)
    cam, _ = stereo_head()
    wall = TexturedPlane(np.random.default_rng(2), origin=(3.0, 0.0, 1.2), e1=(0, -1, 0),
                         e2=(0, 0, -1), size_m=4.0, tex_px=800)
    bg = wall.render(cam)
    base = np.array([[1.0, 0.25, 1.35], [1.0, -0.25, 1.35], [1.1, 0.2, 1.0], [1.1, -0.2, 1.0]])
    axes = [(10, 7), (8, 12), (14, 9), (9, 9)]
    frames, centres = [], []
    for f in range(n):
        p = base + 0.1 * np.sin(2 * np.pi * f / 90 + np.arange(4)[:, None]
                                + np.array([0, 1.1, 2.2]))
        uv = cam.project_base(p)
        img = bg.copy()
        for k in range(4):
            draw_ellipse(img, uv[k], axes[k], 20 * k)
        frames.append(add_noise(img, rng, 4.0))
        centres.append(uv)
    return frames, np.asarray(centres), axes


def bench_em(repeats: int) -> list[Row]:
    from humimic.perception.blobs.em_blobs import BlobTracker

    lut, source = skin_lut()
    frames, centres, axes = synthetic_blob_frames()
    rows = []
    for K in (1, 2, 4):
        def run_sequence(K: int = K) -> float:
            tracker = BlobTracker([lut] * K)
            for k in range(K):
                tracker.start(k, centres[0, k], np.diag(np.square(axes[k]) / 4.0))
            t0 = _now()
            for img in frames:
                tracker.update(img)
            return (_now() - t0) / len(frames)

        run_sequence()
        values = [run_sequence() for _ in range(repeats)]
        rows.append(row("perception", f"EM blob tracker, {K} blob{'s' * (K > 1)}, one image",
                        values, "us", 1e6,
                        note=f"synthetic 320x240 frames, colour model: {source}"))
    return rows


def bench_stereo(repeats: int, seq) -> list[Row]:
    """``StereoRig(...)`` + ``match_many`` per stereo frame on rendered frames, blob centres
    and shapes from ground truth (the stage's inputs), 1 and 3 targets."""
    from humimic.perception.blobs.stereo import StereoRig

    L, R = seq.cameras
    C = np.eye(2) * PIXEL_STD**2
    n = seq.n_frames
    rows = []
    for targets in ([1], [0, 1, 2]):
        ok = []

        def frame(i: int, targets=targets, ok=ok):
            rig = StereoRig(seq.models[L][i], seq.models[R][i])
            ms = rig.match_many(seq.images[L][i], seq.images[R][i],
                                seq.gt_uv[L][i, targets], seq.mask_cov[L][i, targets],
                                seq.gt_uv[R][i, targets], seq.mask_cov[R][i, targets], C, C)
            ok.extend(m.ok for m in ms)

        counter = iter(range(10**9))
        values = per_call(lambda c=counter: frame(next(c) % n), repeats, n)
        k = len(targets)
        rows.append(row("perception", f"stereo ZNCC + triangulation, {k} target"
                        f"{'s' * (k > 1)}", values, "us", 1e6,
                        note=f"rendered wave, stereo 320x240; matched {np.mean(ok):.0%}"))
    return rows


def bench_kalman(repeats: int) -> list[Row]:
    from humimic.estimation.random_jerk import B_PAPER_SI, RandomJerkFilter, predict, update

    rng = np.random.default_rng(0)
    n = 2000
    z = rng.normal(0, 0.01, (n, 3)) + np.array([1.2, -0.2, 1.4])
    R = np.eye(3) * 1e-4

    def sequence():
        kf = RandomJerkFilter(B_PAPER_SI)
        for i in range(n):
            kf.step(i / 60.0, z[i], R)

    values = per_call(sequence, repeats, 1)
    xb = np.zeros((4, 9))
    Pb = np.repeat(np.eye(9)[None], 4, 0)
    zb, Rb = np.zeros((4, 3)), np.repeat(R[None], 4, 0)

    def batched():
        nonlocal xb, Pb
        xb, Pb = update(*predict(xb, Pb, 1 / 60, B_PAPER_SI), zb, Rb)

    return [row("filter", "Kalman step (predict + update), 1 target", [v / n for v in values],
                "us", 1e6, note="RandomJerkFilter.step"),
            row("filter", "Kalman step, 4 targets batched", per_call(batched, repeats, 500),
                "us", 1e6, note="pure predict/update over a (4, 9) batch")]


def bench_ik(repeats: int, ticks: int = 420) -> list[Row]:
    try:
        from humimic.control.config import IKConfig
        from humimic.control.ik import MimicIK, build_robot_model
    except ImportError as exc:
        return [skipped("control", "IK solve, 2 hands, all tasks and limits", "us",
                        f"the control package's IK is not importable ({exc})")]
    dt = 1.0 / 420.0
    model = build_robot_model()
    q0 = model.key("ready").qpos if model.nkey else np.zeros(model.nq)
    ik = MimicIK(model, q0, ["R_palm", "L_palm"], IKConfig(), dt)
    p0 = ik.site_positions().copy()
    k = 0

    def tick():
        nonlocal k
        phase = 2 * np.pi * 0.5 * k * dt
        ik.step(p0 + 0.2 * np.array([0.3 * np.sin(phase), np.sin(phase), np.cos(phase) - 1.0]))
        k += 1

    values = per_call(tick, repeats, ticks, warmup=50)
    return [row("control", "IK solve, 2 hands, all tasks and limits", values, "us", 1e6,
                note="MimicIK.step (mink + daqp), hands on 0.2 m circles, 420 Hz")]


def closed_loop_scenario(duration: float):
    """mimic_wave.yaml with tracked perception (stereo 60 Hz, 420 Hz servo), or a reason."""
    from humimic.scenario import Scenario, ScenarioError, load_scenario

    fields = set(Scenario.model_fields)
    missing = {"perception", "filter", "mimic"} - fields
    if missing:
        return None, f"scenario sections {sorted(missing)} are not in the schema yet"
    overrides = ["mimic.perception=tracked", "mimic.start=0.5", "filter={}",
                 "perception={targets: [head, right_hand], detection: {period: 0.0}}",
                 "output.plots=false", 'output.rerun="off"']
    try:
        return load_scenario(ROOT / "scenarios" / "mimic_wave.yaml", overrides,
                             duration=duration), ""
    except ScenarioError as err:
        return None, f"closed-loop scenario does not validate: {err}"


def bench_loops(repeats: int, duration: float = 4.0) -> list[Row]:
    """Real-time factor of the world alone, oracle mimicry, and the whole tracked loop."""
    from humimic.run import run_one
    from humimic.scenario import ScenarioError, load_scenario

    rows = []
    loop, reason = closed_loop_scenario(duration)
    oracle = load_scenario(ROOT / "scenarios" / "mimic_wave.yaml",
                           ["output.plots=false", 'output.rerun="off"'], duration=duration)
    cases = [("closed loop: perception + filter + mimicry, stereo 60 Hz, 420 Hz servo", loop,
              reason),
             ("loop with oracle perception + mimicry (no vision)", oracle, "")]
    for name, scenario, why in cases:
        if scenario is None:
            rows.append(skipped("loop", name, "x real time", why))
            continue
        rtf, stages = [], {}
        try:
            for _ in range(repeats):
                with tempfile.TemporaryDirectory() as tmp:
                    m = run_one(scenario, tmp, rerun="off", progress=False)
                rtf.append(m["realtime_factor"])
                stages = {k: v["mean_ms"] for k, v in m["stages"].items()}
        except (ScenarioError, RuntimeError, ValueError) as exc:
            rows.append(skipped("loop", name, "x real time", f"run failed: {exc}"))
            continue
        rows.append(row("loop", name, rtf, "x real time",
                        note=f"{duration:g} s of mimic_wave", stage_mean_ms=stages))
    return rows


def _now() -> float:
    import time

    return time.perf_counter()
