"""Does the scripted person stay in the robot's view, in front of the robot?

The avatar is kinematic: its whole motion is known before the loop starts, so the world checks
it once when it is built (:func:`person_view`), every ``1 / RATE`` s of the run (at most
:data:`MAX_SAMPLES` times: 1.6 s of CPU for a 10-minute run, 0.01 s for 6 s), against the eye
cameras at their start pose (their camera models' projection). The eyes may turn during the run
(gaze), so this is the view the run starts with, not every frame's. A motion clip's own root
travel can walk the person out of the image or through the robot, and every score after that
is of a person the robot cannot see. The result is ``metrics.json``'s ``person_view``:

* ``out_of_view_fraction``: samples at which none of :data:`PARTS` projects inside any eye
  camera's image (``first_out_of_view_s``: the first such sample's time, or None);
* ``min_front_distance_m``: the least distance of the :data:`BODY` in front of the eyes' midpoint,
  along the robot's forward axis (base ``x``); negative: behind the eyes, i.e. the person
  passed through the robot (``min_front_distance_t_s``: when);
* ``warning``: one line when the person is out of view on more than :data:`OUT_OF_VIEW` of the
  run or comes nearer than :data:`MIN_FRONT_DISTANCE_M` in front of the eyes; None otherwise.
  The world logs it once when it is built; the run's warning line and the report repeat it.
"""

from __future__ import annotations

import logging

import numpy as np

#: Samples per second of the check ...
RATE = 10.0
#: ... and at most this many over a run (a long run is checked more sparsely).
MAX_SAMPLES = 600
#: The person's parts checked: the person is out of view when none of them is in an image (a
#: foveal eye on a hand sees the hand only).
PARTS = ("head", "pelvis", "right_hand", "left_hand", "right_elbow", "left_elbow")
#: Those of :data:`PARTS` whose distance in front of the eyes counts (the body, not a reach).
BODY = ("head", "pelvis")
#: Warn when the person is out of view on more than this share of the run.
OUT_OF_VIEW = 0.1
#: Warn when a part comes nearer than this (m) in front of the eyes (negative: behind them).
MIN_FRONT_DISTANCE_M = 0.3

log = logging.getLogger(__name__)


def view_summary(t: np.ndarray, seen: np.ndarray, front_m: np.ndarray) -> dict:
    """The ``person_view`` section from sample times ``t (N,)``, whether the person was in
    view at each ``seen (N,)`` and each part's distance in front of the eyes ``front_m (N, P)``
    (see the module docstring; no samples: no warning)."""
    if len(t) == 0:
        return {"samples": 0, "out_of_view_fraction": None, "first_out_of_view_s": None,
                "min_front_distance_m": None, "min_front_distance_t_s": None, "warning": None}
    out = ~np.asarray(seen, bool)
    nearest = np.min(front_m, axis=1)
    k = int(np.argmin(nearest))
    s = {"samples": len(t), "out_of_view_fraction": float(out.mean()),
         "first_out_of_view_s": float(t[np.argmax(out)]) if out.any() else None,
         "min_front_distance_m": float(nearest[k]), "min_front_distance_t_s": float(t[k])}
    why = []
    if s["out_of_view_fraction"] > OUT_OF_VIEW:
        why.append(f"is out of the eye cameras' start view on {s['out_of_view_fraction']:.0%} "
                   f"of the run (from {s['first_out_of_view_s']:.1f} s)")
    d, when = s["min_front_distance_m"], s["min_front_distance_t_s"]
    if d < 0.0:
        why.append(f"passes through the robot ({-d:.2f} m behind its eyes at {when:.1f} s)")
    elif d < MIN_FRONT_DISTANCE_M:
        why.append(f"comes within {d:.2f} m in front of the robot's eyes (at {when:.1f} s)")
    s["warning"] = (f"the scripted person {' and '.join(why)}: the robot cannot see them then, "
                    "and the scores of those times are not of imitation (check human.distance "
                    "and the motion's root travel)" if why else None)
    return s


def person_view(world) -> dict | None:
    """Check the world's person against its eye cameras at their current (start) pose; logs
    the warning, if any, once. None without eye cameras."""
    rig = world.eye_rig
    if rig is None or not world.eye_cameras:
        return None
    duration = world.scenario.duration
    rate = world.clock.physics_rate
    t = np.linspace(0.0, duration, min(int(duration * RATE), MAX_SAMPLES) + 1)
    ticks = np.clip(np.rint(t * rate).astype(int), 0, world.n_ticks - 1)
    gt = world.gt.at(ticks)  # every part at once: each sample is evaluated once
    p = np.stack([gt.p_base(part) for part in PARTS], axis=1)
    seen = np.zeros(len(t), bool)
    for name in world.eye_cameras:
        cam = rig.camera_model(name)
        seen |= cam.intrinsics.contains(cam.project_base(p)).any(axis=1)
    scene = world.scene
    T_wb = scene.T_world_base
    p_eyes = (scene.data.site_xpos[scene.robot_site("eye_center")] - T_wb[:3, 3]) @ T_wb[:3, :3]
    body = [PARTS.index(part) for part in BODY]
    s = view_summary(t, seen, p[:, body, 0] - p_eyes[0])
    if s["warning"]:
        log.warning("%s", s["warning"])
    return s
