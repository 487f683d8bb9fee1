"""Rendered eye-camera sequences of the humimic scene with ground truth, for the benchmarks.

A sequence is a scripted person (a scenario's ``human`` section, e.g. keyframes) rendered by
the scenario's own :class:`~humimic.world.world.World` and :class:`CameraRig` at the camera
rate, with, per frame and camera: the image (with the scenario's pixel noise), the camera model,
the true pixel position of each target (its site projected) and the pixel mean and covariance
of its visible skin (MuJoCo segmentation), the latter used only to initialise trackers.
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

from dataclasses import dataclass, field

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import mujoco
import numpy as np

from humimic.rngs import Rngs
from humimic.scenario import validate_scenario
from humimic.world.world import World

#: Target -> the avatar geom that shows it.
TARGET_GEOMS = {"head": "human/head", "right_hand": "human/r_hand", "left_hand": "human/l_hand"}


@dataclass
class Sequence:
    name: str
    cameras: list[str]
    targets: list[str]
    images: dict[str, list[np.ndarray]] = field(default_factory=dict)
    models: dict[str, list] = field(default_factory=dict)
    gt_uv: dict[str, np.ndarray] = field(default_factory=dict)
    """camera -> (frames, targets, 2) true pixel positions."""
    mask_mean: dict[str, np.ndarray] = field(default_factory=dict)
    """camera -> (frames, targets, 2) centroid of the target's visible pixels (NaN if none)."""
    mask_cov: dict[str, np.ndarray] = field(default_factory=dict)
    """camera -> (frames, targets, 2, 2) pixel covariance of its visible pixels."""
    skin_pixels: np.ndarray | None = None
    """(N, 3) uint8 skin pixels of the first frame (all targets, first camera)."""

    @property
    def n_frames(self) -> int:
        return len(self.images[self.cameras[0]])


def render_sequence(name: str, human: dict, duration: float, cameras: str = "stereo",
                    targets: tuple[str, ...] = ("head", "right_hand", "left_hand"),
                    noise_std: float = 2.0, seed: int = 0, rate: float = 60.0) -> Sequence:
    """Render ``duration`` seconds of ``human`` (a scenario ``human`` section) at ``rate``."""
    scenario = validate_scenario({
        "name": f"bench-{name}", "duration": duration, "seed": seed, "human": human,
        "cameras": {"which": "wide", "eyes": cameras, "resolution": [320, 240], "rate": rate,
                    "noise_std": noise_std},
        "output": {"rerun": "off", "plots": False}})
    world = World(scenario, Rngs(seed))
    m, d = world.scene.model, world.scene.data
    seq = Sequence(name, list(world.eye_cameras), list(targets))
    geoms = np.array([m.geom(TARGET_GEOMS[t]).id for t in targets])
    gt_base = np.stack([world.gt.p_base(t) for t in targets], axis=1)  # (ticks, T, 3)
    every = int(round(scenario.timing.physics_rate / rate))
    try:
        for cam in seq.cameras:
            seq.images[cam], seq.models[cam] = [], []
        uv = {c: [] for c in seq.cameras}
        mm = {c: [] for c in seq.cameras}
        mc = {c: [] for c in seq.cameras}
        for tick in range(0, world.n_ticks, every):
            world.apply_human(tick)
            mujoco.mj_forward(m, d)
            for cam, shot in world.eye_rig.capture(tick / scenario.timing.physics_rate).items():
                seq.images[cam].append(shot.image)
                seq.models[cam].append(shot.camera)
                uv[cam].append(shot.camera.project_base(gt_base[tick]))
                seg = world.eye_rig.render_ideal(cam, segmentation=True)
                is_geom = seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
                means, covs = [], []
                for g in geoms.tolist():
                    vs, us = np.nonzero(is_geom & (seg[..., 0] == g))
                    if len(us) < 3:
                        means.append([np.nan, np.nan])
                        covs.append(np.full((2, 2), np.nan))
                        continue
                    means.append([us.mean(), vs.mean()])
                    covs.append(np.cov(np.stack([us, vs])))
                mm[cam].append(means)
                mc[cam].append(covs)
                if tick == 0 and cam == seq.cameras[0]:
                    skin = is_geom & np.isin(seg[..., 0], geoms)
                    seq.skin_pixels = shot.image[skin]
        for cam in seq.cameras:
            seq.gt_uv[cam] = np.asarray(uv[cam])
            seq.mask_mean[cam] = np.asarray(mm[cam], float)
            seq.mask_cov[cam] = np.asarray(mc[cam], float)
    finally:
        world.close()
    return seq


#: Scripted sequences for the tracker comparison (avatar frame, m; palms and head centre).
CROSSING_HANDS = {
    "distance": 1.2,
    "motion": {"kind": "keyframes", "interpolation": "min_jerk", "frames": [
        {"t": 0.0, "right_hand": [0.30, -0.25, 1.20], "left_hand": [0.25, 0.25, 1.20]},
        {"t": 1.5, "right_hand": [0.36, 0.22, 1.22], "left_hand": [0.24, -0.22, 1.18]},
        {"t": 3.0, "right_hand": [0.30, -0.25, 1.20], "left_hand": [0.25, 0.25, 1.20]},
    ]},
}
HAND_PASSES_FACE = {
    "distance": 1.2,
    "motion": {"kind": "keyframes", "interpolation": "min_jerk", "frames": [
        {"t": 0.0, "right_hand": [0.25, -0.40, 1.62]},
        {"t": 1.5, "right_hand": [0.28, 0.20, 1.64]},
        {"t": 3.0, "right_hand": [0.25, -0.40, 1.62]},
    ]},
}
WAVE = {"distance": 1.2, "motion": {"kind": "wave", "hand": "right", "ramp": 0.0}}
