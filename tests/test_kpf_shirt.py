"""Table 1's ``kpf`` likelihood prefers the true arm for a shirt other than the default blue
(issue 14, ``i14-shirt``): on rendered frames of a person in a green shirt at rest, the truth
outscores random poses of the right arm whose wrist is 40 mm or more away on nearly every frame.

The forearm is in the shirt's sleeve; with the paper's forearm cues (edge, ridge) alone the
green sleeve's ridge is weak at the true axis and a pose beside it won 5 of these 9 frames (the
maximum-likelihood wrist 53 mm off on average); with the mean-colour cue on the forearm too
(``cues.forearm: [edge, ridge, colour]``, Table 1's ``kpf``) 1 of 9 (6 mm)."""

from __future__ import annotations

import numpy as np
import pytest

from humimic import bodymodel as bm
from humimic.paths import SCENARIOS_DIR
from humimic.perception.trackers.common import check_camera, skin_model_lut
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.pipeline.simulation import simulate
from humimic.pipeline.stage import Stage
from humimic.rngs import Rngs
from humimic.scenario.load import load_scenario
from humimic.sensors.camera_model import invert_transform
from humimic.viz.rerun_log import RerunLog
from humimic.world.world import World

GREEN = "[0.2,0.5,0.25]"


class Frames(Stage):
    """Keeps one camera's frames with the true pose."""

    name = "frames_probe"

    def __init__(self, world, camera: str):
        self.world, self.camera, self.rows = world, camera, []

    def attach(self, bus, timer) -> None:
        bus.subscribe("frames", self._on)

    def _on(self, topic, msg) -> None:
        f = msg.value.get(self.camera)
        if f is not None:
            q = bm.truth_state(self.world, self.world.gt.index_of(msg.t), "base")
            self.rows.append((f.image.copy(), invert_transform(f.camera.T_base_cam), q,
                              f.camera.intrinsics))


@pytest.fixture(scope="module")
def green_rest():
    """Table 1's scenario, the person in a green shirt, the first 1.2 s (at rest): the kpf's
    config, its skin model and the frames (image, T_cam_base, true pose, intrinsics)."""
    sc = load_scenario(SCENARIOS_DIR / "schmidt_table1.yaml",
                       [f"human.shirt={GREEN}", "human.motion.gestures=[side]"], seed=0,
                       duration=1.2)
    world = World(sc, Rngs(sc.seed))
    try:
        cfg = sc.trackers["kpf"]
        camera = check_camera(sc, world, "kpf", cfg.camera)
        lut = skin_model_lut(sc, world, [camera], "trackers.kpf")
        probe = Frames(world, camera)
        simulate(world, [probe], RerunLog(world.scene, "off", None, "test"), progress=False)
    finally:
        world.close()
    return cfg, lut, probe.rows


def test_truth_beats_arm_poses_40mm_off_in_a_green_shirt(green_rest):
    cfg, lut, rows = green_rest
    body = kpf_body()
    rng = np.random.default_rng(0)
    lik = None
    beaten = 0
    for image, T, q_true, intr in rows:
        maps = FrameCues(image, lut, colour_gradients=cfg.colour_gradients)
        if lik is None:
            lik = Likelihood(body, intr, cfg)
        # eq. 7 as a tracker following the truth
        lik.adapt({k: v[0] for k, v in lik.evaluate(q_true[None], maps, T).colours.items()})
        q = np.repeat(q_true[None], 201, axis=0)
        q[1:, 6:10] += rng.normal(0.0, 1.0, (200, 4)) * np.radians([12, 12, 20, 15])
        q = body.free_limits.clamp(q)
        ll = lik.evaluate(q, maps, T).log_lik
        wrist = body.forward(q).joint("r_wrist")
        far = np.linalg.norm(wrist - wrist[0], axis=1) >= 0.04
        beaten += bool(np.any(ll[far] > ll[0]))
    assert len(rows) == 9
    assert beaten <= 3          # measured 1 of 9 (without the forearm's colour cue 5 of 9)
