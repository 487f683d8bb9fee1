"""Measure how well Table 1's frames observe the wrist's depth (issue 14): the tracker's own
likelihood profiled along the true wrist's camera ray and at its kinematic mirrors, every frame.

``python -m humimic.perception.reproduce schmidt-depth-profile [--gesture side angle] [--eye
wide|foveal] [--seeds S ...] [--set KEY=VALUE ...] [--tracker kpf] [--range MM] [--step MM]
[--torso-offset X Y Z] [--gaze TARGET ...] [--out DIR] [--from DIR] [--scale K]`` renders
``scenarios/schmidt_table1.yaml``'s frames (``--eye foveal``: its foveal variant) for each
gesture and seed -- no tracker runs -- and on each frame evaluates
:func:`~humimic.perception.trackers.kpf.profile.depth_profile` around the TRUE pose with the
likelihood (eqs. 9-10, :class:`~humimic.perception.trackers.kpf.likelihood.Likelihood`) of
the scenario's tracker ``--tracker`` (default ``kpf``, Table 1's; with
``sigma_from_spread`` its sigmas are the floors, the sharpest it can get), its colour
references adapted from the true pose (eq. 7) as a tracker following the truth would.

Per gesture phase (rest, rise, hold, lower; :func:`phase`) it prints the widths (mm) of the
depth intervals around the truth over which the log-likelihood stays within 0.5 and 2 nats
of the truth's (:func:`~humimic.perception.trackers.kpf.profile.within`), the offset of the
profile's maximum (the depth error of an ideal maximum-likelihood search along the ray), the
wrist error of a maximum-likelihood choice among the ray's poses and the mirrors, and the
mirrors' margin (truth minus the best mirror, nats). ``--out`` gets ``profile.json`` (every
frame) and ``depth_profile.png`` (the mean profile per gesture and phase). Also printed: the
stereo arithmetic (the eyes' baseline from the robot model, the disparity change a depth
change makes at the person's distance), what a second eye would add. ``--torso-offset``
(mm, base frame) profiles around the truth with its torso moved (a tracker's torso error; the
errors stay to the true wrist); ``--from DIR`` re-summarises a ``profile.json`` and ``--scale
K`` multiplies the log-likelihoods by K first (the cue sigmas divided by sqrt K). ``--gaze
right_elbow right_wrist`` (with ``--set cameras.which=foveal``) keeps the eyes on the true arm
(:class:`TruthGaze`): the narrow camera's view of the arm at Table 1's 2 m.
"""

from __future__ import annotations

import numpy as np

from humimic import bodymodel as bm
from humimic.motion.primitives import point_cycle
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.profile import depth_profile, ml_choice, ml_wrist, within
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.pipeline.stage import Stage
from humimic.sensors.camera_model import invert_transform

PHASES = ("rest", "rise", "hold", "lower")
NATS = (0.5, 2.0)


def phase(t: np.ndarray, motion) -> np.ndarray:
    """The pointing motion's phase index into :data:`PHASES` at times ``t`` (s): each gesture
    of :class:`~humimic.motion.config.PointMotion` is ``rest``, ``move`` (rise), ``hold``,
    ``move`` (lower) (:func:`humimic.motion.primitives.point_cycle`)."""
    _, tau = point_cycle(t, motion)
    return np.searchsorted(np.cumsum([motion.rest, motion.move, motion.hold]), tau,
                           side="right")


class ProfileProbe(Stage):
    """Profiles the likelihood around the true pose on every frame of ``camera``, or around
    the true pose with its torso moved by ``torso_offset`` (m, base frame: a tracker's torso
    error), the errors always to the true wrist."""

    name = "depth_profile"

    def __init__(self, world, camera: str, cfg, skin_lut, delta: np.ndarray,
                 torso_offset=(0.0, 0.0, 0.0)):
        self.world, self.camera, self.cfg, self.lut = world, camera, cfg, skin_lut
        self.offset = np.asarray(torso_offset, float)
        self.body = kpf_body(world.scene.model)
        self.delta = delta
        self.lik: Likelihood | None = None
        self.rows: list[dict] = []
        self.fx = float("nan")

    def attach(self, bus, timer) -> None:
        bus.subscribe("frames", self._on_frames)

    def _on_frames(self, topic: str, msg) -> None:
        frame = msg.value.get(self.camera)
        if frame is None:
            return
        T = invert_transform(frame.camera.T_base_cam)
        q_true = bm.truth_state(self.world, self.world.gt.index_of(msg.t), "base")
        q = q_true.copy()
        q[:3] += self.offset
        maps = FrameCues(frame.image, self.lut, colour_gradients=self.cfg.colour_gradients)
        if self.lik is None:    # as the tracker's start: the references from the first pose
            self.fx = float(frame.camera.intrinsics.fx)
            self.lik = Likelihood(self.body, frame.camera.intrinsics,
                                  self.cfg.model_copy(update={"sigma_from_spread": False}))
            self.lik.adapt({k: v[0] for k, v in
                            self.lik.evaluate(q[None], maps, T).colours.items()})
        p = depth_profile(self.body, lambda qs: self.lik.evaluate(qs, maps, T).log_lik,
                          q, T, self.delta)
        kind, _ = ml_choice(p)
        w = self.body.forward(q_true[None]).joint("r_wrist")[0]
        row = {"t": float(msg.t), "range_m": float(np.linalg.norm(w - np.linalg.inv(T)[:3, 3])),
               "log_lik": (p.log_lik - p.truth).tolist(), "ml": kind,
               "ml_error_m": float(np.linalg.norm(ml_wrist(p) - w)),
               "ray_error_m": np.linalg.norm(p.wrist - w, axis=1).tolist(),
               "flip_error_m": {k: float(np.linalg.norm(v - w)) for k, v in p.flip_wrist.items()},
               "ray_offset_m": float(p.delta[np.nanargmax(p.log_lik)]),
               "flip_margin": p.flip_margin, "flip_wrist_m": p.flip_wrist_m,
               "flip_rel": {k: v - p.truth for k, v in p.flip_log_lik.items()}}
        for n in NATS:
            lo, hi, cens = within(p.delta, p.log_lik, p.truth, n)
            row[f"within_{n:g}"] = [lo, hi, cens]
        self.rows.append(row)
        # eq. 7 as a tracker whose estimate is the truth
        self.lik.adapt({k: v[0] for k, v in self.lik.evaluate(q[None], maps, T).colours.items()})


class TruthGaze(Stage):
    """Our probe of foveated active gaze (issue 14; not in the paper): before every servo tick
    both eyes are turned (set, not servoed) so their axes -- the wide and foveal cameras are
    coaxial -- meet the mean of the TRUE positions of the human ``targets`` (e.g.
    ``right_elbow right_wrist``): an ideal gaze on the arm, the upper bound of one that follows
    a tracker's estimate."""

    name = "truth_gaze"

    def __init__(self, world, targets: list[str]):
        self.world = world
        self.p_world = np.mean([world.gt.p_world(t) for t in targets], axis=0)

    def servo(self, t: float, bus) -> None:
        w = self.world
        w.look_at_point(self.p_world[w.gt.index_of(t)])


def eye_baseline(world) -> float:
    """The distance (m) between the robot's two eyes (the bodies ``L_eye``, ``R_eye`` of the
    robot model, children of its head)."""
    from humimic.world.names import ROBOT_PREFIX

    m = world.scene.model
    return float(np.linalg.norm(m.body(f"{ROBOT_PREFIX}L_eye").pos
                                - m.body(f"{ROBOT_PREFIX}R_eye").pos))


def disparity_change(f_px: float, baseline: float, z: float, dz: float) -> float:
    """Change (px) of a stereo disparity ``f b / z`` when the depth goes from ``z`` to
    ``z + dz`` (m)."""
    return f_px * baseline * (1.0 / z - 1.0 / (z + dz))


def profile_run(scenario, tracker: str, delta: np.ndarray, torso_offset=(0.0, 0.0, 0.0),
                gaze: list[str] | None = None) -> tuple[list[dict], dict]:
    """Render ``scenario`` and profile each frame (:class:`ProfileProbe`), the eyes on the
    true ``gaze`` targets' mean if given (:class:`TruthGaze`); ``(rows, info)``."""
    from humimic.perception.trackers.common import check_camera, skin_model_lut
    from humimic.pipeline.simulation import simulate
    from humimic.rngs import Rngs
    from humimic.viz.rerun_log import RerunLog
    from humimic.world.world import World

    cfg = scenario.trackers[tracker]
    rngs = Rngs(scenario.seed)
    world = World(scenario, rngs)
    try:
        camera = check_camera(scenario, world, tracker, cfg.camera)
        lut = skin_model_lut(scenario, world, [camera], f"trackers.{tracker}")
        probe = ProfileProbe(world, camera, cfg, lut, delta, torso_offset)
        rlog = RerunLog(world.scene, "off", None, "depth-profile")
        stages = [probe] if not gaze else [TruthGaze(world, gaze), probe]
        simulate(world, stages, rlog, progress=False)
        info = {"fx_px": probe.fx, "baseline_m": eye_baseline(world)}
    finally:
        world.close()
    ph = phase([r["t"] for r in probe.rows], scenario.human.motion)
    for r, k in zip(probe.rows, ph, strict=True):
        r["phase"] = PHASES[k]
    return probe.rows, info
