"""Position-servo feed-forward, checked against MuJoCo's own actuator and passive forces."""

from __future__ import annotations

import mujoco
import numpy as np

from humimic.control.servo import Servo, servo_command
from humimic.world.scene import build_scene


def test_feedforward_makes_the_servo_apply_the_requested_torque():
    """At q = q_d, qdot = qdot_d the position actuators plus joint damping must exert exactly
    tau_ff (MuJoCo computes the forces; we only chose ctrl)."""
    scene = build_scene()
    m, d = scene.model, scene.data
    rng = np.random.default_rng(0)
    lo, hi = scene.robot_range.T
    q_d = rng.uniform(lo + 0.2, hi - 0.2)
    qdot_d = rng.normal(0, 0.5, len(q_d))
    tau_ff = rng.normal(0, 0.1, len(q_d))
    servo = Servo(m, d, scene.robot_actuators, scene.robot_dof, "velocity")
    g = servo.gains
    ctrl = servo_command(q_d, qdot_d, tau_ff, g.kp, g.kv, g.b)
    d.qpos[scene.robot_qpos] = q_d
    d.qvel[scene.robot_dof] = qdot_d
    d.ctrl[scene.robot_actuators] = ctrl
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL  # test the law, not the range
    mujoco.mj_forward(m, d)
    dofs = scene.robot_dof
    force = d.qfrc_actuator[dofs] - m.dof_damping[dofs] * d.qvel[dofs]
    np.testing.assert_allclose(force, tau_ff, atol=1e-9)


def test_inverse_dynamics_term_is_mass_matrix_times_qdd():
    scene = build_scene()
    m, d = scene.model, scene.data
    mujoco.mj_forward(m, d)
    servo = Servo(m, d, scene.robot_actuators, scene.robot_dof, "dynamics")
    qdd = np.random.default_rng(1).normal(size=len(scene.robot_dof))
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    dofs = scene.robot_dof
    np.testing.assert_allclose(servo.inverse_dynamics(qdd), M[np.ix_(dofs, dofs)] @ qdd,
                               atol=1e-12)


def test_none_feedforward_commands_the_target_itself():
    scene = build_scene()
    servo = Servo(scene.model, scene.data, scene.robot_actuators, scene.robot_dof, "none")
    q = scene.data.qpos[scene.robot_qpos].copy()
    ctrl = servo.command(q, np.ones_like(q), np.ones_like(q))
    np.testing.assert_array_equal(ctrl, q)


def test_decimator_lets_through_the_first_and_every_nth_call():
    from humimic.control.decimate import Decimator

    turns = Decimator(3)
    assert [turns() for _ in range(8)] == [0, None, None, 1, None, None, 2, None]
    assert [Decimator(0)() for _ in range(2)] == [0, 0]  # every < 1 means every call
