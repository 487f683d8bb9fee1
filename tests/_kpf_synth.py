"""A synthetic scene for the kernel particle filter's tests: a camera 2 m in front of the
body model and the model rasterised in flat colours (skin-coloured head and hands, distinct
limb colours) at a static pose, the right arm raised to the side."""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from humimic import bodymodel as bm
from humimic.sensors.camera_model import Intrinsics

INTRINSICS = Intrinsics(320, 240, 260.0, 260.0, 159.5, 119.5)

PALETTE = {"torso": (40, 60, 160), "head": (224, 172, 140), "r_hand": (224, 172, 140),
           "l_hand": (224, 172, 140), "r_upper_arm": (200, 40, 40),
           "l_upper_arm": (200, 40, 40), "r_forearm": (230, 200, 60),
           "l_forearm": (230, 200, 60)}


def facing_arm_poses(body: bm.BodyModel, rng: np.random.Generator, n: int, low, high,
                     arms: slice = slice(6, 10)) -> np.ndarray:
    """``n`` poses of a person facing the camera (torso at the base origin, turned by pi), the
    ``arms`` DOFs (default the right arm's four) uniform in ``[low, high)``, clamped to the
    body's limits."""
    q = np.zeros((n, 14))
    q[:, 3] = np.pi
    q[:, arms] = rng.uniform(low, high, (n, q[:, arms].shape[1]))
    return body.free_limits.clamp(q)


def camera() -> np.ndarray:
    """T_cam_base of a camera 2 m in front of the body looking back at it (OpenCV axes)."""
    R_base_cam = np.column_stack([[0, 1, 0], [0, 0, -1], [-1, 0, 0]]).astype(float)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_base_cam.T, -R_base_cam.T @ np.array([2.0, 0.0, 0.2])
    return T


def static_pose() -> np.ndarray:
    """The 14-DOF pose: facing the camera, the right arm raised to the side."""
    q0 = np.zeros(14)
    q0[3] = np.pi
    q0[6:10] = [0.3, 0.9, 0.0, 0.6]
    q0[10:14] = [0.1, 0.2, 0.0, 0.3]
    return q0


def painted_person(body: bm.BodyModel, q0: np.ndarray, T_cam_base: np.ndarray) -> np.ndarray:
    """The body model at ``q0`` rasterised in ``PALETTE``'s colours on a grey wall (RGB)."""
    labels = bm.label_mask(bm.project(body, body.forward(q0[None]), INTRINSICS, T_cam_base))
    img = np.full((INTRINSICS.height, INTRINSICS.width, 3), 90, np.uint8)
    for p, name in enumerate(body.part_names):
        img[labels == p + 1] = PALETTE.get(name, (128, 128, 128))
    return img


def propagated_wrist_ranges(monkeypatch, cfg) -> tuple[np.ndarray, float]:
    """One kpf step from :func:`static_pose` on its painted image (every ancestor the same):
    the camera distances (m) of the right wrists of the particles handed to mean shift (the
    propagation's output, caught with a spy on ``kpf_modes``), and the start pose's."""
    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model
    from humimic.perception.trackers.kpf import tracker as tracker_mod
    from humimic.perception.trackers.kpf.frame_cues import FrameCues

    seen: list = []
    kpf_modes = tracker_mod.kpf.kpf_modes

    def spy(particles, *a, **k):
        seen.append(particles.copy())
        return kpf_modes(particles, *a, **k)
    monkeypatch.setattr(tracker_mod.kpf, "kpf_modes", spy)
    body, T, q0 = tracker_mod.kpf_body(), camera(), static_pose()
    img = painted_person(body, q0, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    r0 = float(np.linalg.norm(body.forward(q0[None]).to(T).joint("r_wrist")[0]))
    tr = tracker_mod.KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(2))
    tr.start(q0, FrameCues(img, lut), T)
    tr.step(FrameCues(img, lut), T)
    return np.linalg.norm(body.forward(seen[-1]).to(T).joint("r_wrist"), axis=1), r0


@contextmanager
def scenario_kpf(name: str, duration: float = 1.0, seed: int = 0):
    """Yields ``(world, kpf_stage)`` after simulating the scenario ``name`` (a file in
    ``scenarios/``) for ``duration`` s at (150, 2) with no rerun output; the world is closed
    after the block."""
    from humimic import select_gl_backend

    select_gl_backend()
    from humimic.paths import SCENARIOS_DIR
    from humimic.pipeline.build import build_stages
    from humimic.pipeline.simulation import simulate
    from humimic.rngs import Rngs
    from humimic.scenario import load_scenario
    from humimic.viz.rerun_log import RerunLog
    from humimic.world.world import World

    sc = load_scenario(SCENARIOS_DIR / name,
                       ["trackers.kpf.n_particles=150", "trackers.kpf.iterations=2"], seed=seed,
                       duration=duration)
    rngs = Rngs(seed)
    world = World(sc, rngs)
    try:
        rlog = RerunLog(world.scene, "off", None, "t")
        stages = build_stages(sc, world, rngs, rlog)
        simulate(world, stages, rlog, progress=False)
        yield world, next(s for s in stages if getattr(s, "name", "") == "kpf")
    finally:
        world.close()
