"""The kpf's linear motion model on the torso (``KpfConfig.torso_velocity``): the velocity is
the last two modes' difference, zero on the torso's DOFs when off; and on a rasterised static
person the paper's torso velocity integrates the mode's jitter into a drift that the torso
predicted in place does not have."""

from __future__ import annotations

import numpy as np
from _kpf_synth import INTRINSICS, camera, painted_person, static_pose

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.tracker import motion_velocity


def test_motion_velocity_is_the_modes_difference_without_the_torso_when_off():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=14), rng.normal(size=14)
    assert np.array_equal(motion_velocity(a, b), a - b)
    v = motion_velocity(a, b, torso=False)
    torso = [bm.DOF_NAMES.index(n) for n in bm.TORSO_DOFS]
    assert np.all(v[torso] == 0.0)
    arms = np.setdiff1d(np.arange(14), torso)
    assert np.array_equal(v[arms], (a - b)[arms])
    assert np.array_equal(a - b, motion_velocity(a, b))   # the inputs untouched


def test_torso_velocity_makes_a_static_torso_drift():
    """The paper's config at (150, 2), 30 frames of a still, rasterised person, seeds 0-3: the
    torso's position error at the last frame with the torso's velocity in the motion model
    (measured 103-394 mm, median 188) against without (30-43 mm)."""
    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model
    from humimic.perception.trackers.kpf.config import KpfConfig
    from humimic.perception.trackers.kpf.frame_cues import FrameCues
    from humimic.perception.trackers.kpf.tracker import KpfTracker, kpf_body

    body, T, q0 = kpf_body(), camera(), static_pose()
    img = painted_person(body, q0, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    last = {}
    for torso in (True, False):
        last[torso] = []
        for seed in range(4):
            cfg = KpfConfig(n_particles=150, iterations=2, kde_stride=4, torso_velocity=torso)
            tr = KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(seed))
            tr.start(q0, FrameCues(img, lut), T)
            for _ in range(30):
                res = tr.step(FrameCues(img, lut), T)
            last[torso].append(np.linalg.norm(res.mode[:3] - q0[:3]))
    assert max(last[False]) < 0.1, last[False]                      # measured <= 43 mm
    assert np.median(last[True]) > 2.0 * np.median(last[False]), last
