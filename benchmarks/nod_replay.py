"""Replay a mimic run's recorded joint references on the robot alone, per servo feed-forward:
the head's nod for the *same* trajectory (a closed loop through the images takes another
trajectory whenever the robot moves differently).

``python benchmarks/nod_replay.py TRACE.npz [MODE ...]`` with a trace saved by
``benchmarks/nod_trace.py --npz`` and modes of ``mimic.servo.feedforward`` (default:
``inertia dynamics``). The robot alone reproduces the scene's run (840 Hz ``implicitfast``,
420 Hz servo): a22's 0.3219 deg replays as 0.3214. Notes: ``docs/ude_control_notes.md``.
"""

from __future__ import annotations

import sys

import mujoco
import numpy as np

from humimic.control.ik import build_robot_model
from humimic.control.servo import Servo

PHYSICS_RATE, SERVO_RATE = 840.0, 420.0


def max_rotation_deg(R: np.ndarray) -> float:
    """Largest rotation (deg) of ``R (n, 3, 3)`` from ``R[0]``."""
    rel = np.einsum("ji,njk->nik", R[0], R)
    cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    return float(np.degrees(np.arccos(cos)).max())


def replay(trace: dict, feedforward: str) -> float:
    """The eyes' base's largest rotation (deg) with the recorded ``q_ik, qdot_ik`` (the
    acceleration as the mimic stage differences it) commanded through ``feedforward``."""
    m = build_robot_model()
    m.opt.timestep = 1.0 / PHYSICS_RATE
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    d = mujoco.MjData(m)
    d.qpos[:] = trace["q_robot"][0]
    mujoco.mj_forward(m, d)
    servo = Servo(m, d, np.arange(m.nu), np.arange(m.nv), feedforward)
    site = m.site("eye_center").id
    dt, sub = 1.0 / SERVO_RATE, int(round(PHYSICS_RATE / SERVO_RATE))
    v_prev, R = np.zeros(m.nv), []
    for q, v in zip(trace["q_ik"], trace["qdot_ik"], strict=True):
        R.append(d.site_xmat[site].reshape(3, 3).copy())
        servo.command(q, v, (v - v_prev) / dt)
        v_prev = v
        for _ in range(sub):
            mujoco.mj_step(m, d)
    return max_rotation_deg(np.array(R))


def main() -> None:
    trace = dict(np.load(sys.argv[1]))
    rec = max_rotation_deg(trace["R_head"].reshape(-1, 3, 3))
    print(f"recorded: {rec:.4f} deg")
    for mode in sys.argv[2:] or ["inertia", "dynamics"]:
        print(f"{mode}: {replay(trace, mode):.4f} deg")


if __name__ == "__main__":
    main()
