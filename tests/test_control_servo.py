"""Position-servo feed-forward, checked against MuJoCo's own actuator and passive forces."""

from __future__ import annotations

import mujoco
import numpy as np

from humimic.control.servo import Servo, servo_command
from humimic.world.names import ROBOT_JOINTS
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


def _moving_scene(seed: int):
    """The scene at a random robot pose and velocity (forward dynamics computed)."""
    scene = build_scene()
    m, d = scene.model, scene.data
    rng = np.random.default_rng(seed)
    lo, hi = scene.robot_range.T
    d.qpos[scene.robot_qpos] = rng.uniform(lo + 0.1, hi - 0.1)
    d.qvel[scene.robot_dof] = rng.normal(0, 2.0, len(scene.robot_dof))
    mujoco.mj_forward(m, d)
    return scene, rng


def test_inertia_feedforward_is_mass_matrix_times_qdd():
    scene, rng = _moving_scene(1)
    m, d = scene.model, scene.data
    servo = Servo(m, d, scene.robot_actuators, scene.robot_dof, "inertia")
    qdd = rng.normal(size=len(scene.robot_dof))
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    dofs = scene.robot_dof
    np.testing.assert_allclose(servo.inverse_dynamics(qdd, velocity_terms=False),
                               M[np.ix_(dofs, dofs)] @ qdd, atol=1e-12)


def test_dynamics_feedforward_is_the_inverse_dynamics_without_gravity():
    """``M qdd + c(q, qdot)``: against MuJoCo's recursive Newton-Euler (``mj_rne``) at the
    moving state minus the same at rest with no acceleration (the gravity alone), plus the
    joints' armature (rotor inertia, on the mass matrix's diagonal): the reference uses
    neither ``qM`` nor ``qfrc_bias`` / ``qfrc_gravcomp`` as the servo does."""
    scene, rng = _moving_scene(2)
    m, d = scene.model, scene.data
    dofs = scene.robot_dof
    servo = Servo(m, d, scene.robot_actuators, dofs, "dynamics")
    qdd = rng.normal(size=len(dofs))
    got = servo.inverse_dynamics(qdd).copy()
    full, gravity = np.zeros(m.nv), np.zeros(m.nv)
    d.qacc[:] = 0.0
    d.qacc[dofs] = qdd
    mujoco.mj_rne(m, d, 1, full)
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)
    mujoco.mj_rne(m, d, 0, gravity)
    rotor = m.dof_armature[dofs] * qdd  # the RNE leaves out the armature; the mass matrix has it
    np.testing.assert_allclose(got, (full - gravity)[dofs] + rotor, atol=1e-9)
    assert np.abs(got - servo.inverse_dynamics(qdd, velocity_terms=False)).max() > 0.1


def _head_rotation_deg(ff: str, seconds: float = 1.5) -> float:
    """Largest rotation of the eyes' base while the right arm waves (shoulder and elbow
    sinusoids at 1 Hz, amplitude 0.6 rad, ~3.8 rad/s peak) on the 420 Hz servo, the trunk
    and neck servos holding their start angles."""
    scene = build_scene()
    m, d = scene.model, scene.data
    servo = Servo(m, d, scene.robot_actuators, scene.robot_dof, ff)
    q0 = d.qpos[scene.robot_qpos].copy()
    arm = [ROBOT_JOINTS.index(j) for j in ("R_SFE", "R_SAA", "R_EB")]
    mid, phase, amp, w = np.array([0.8, 0.6, 0.8]), np.array([0.0, 1.0, 2.0]), 0.6, 2 * np.pi
    site = scene.robot_site("eye_center")
    dt = 1.0 / 420.0
    sub = int(round(dt / m.opt.timestep))
    R = []
    for k in range(int(seconds / dt)):
        t = (k + 0.5) * dt  # the middle of the servo period, as the mimic stage aims
        q, v, a = q0.copy(), np.zeros_like(q0), np.zeros_like(q0)
        q[arm] = mid + amp * np.sin(w * t + phase)
        v[arm] = amp * w * np.cos(w * t + phase)
        a[arm] = -amp * w * w * np.sin(w * t + phase)
        if k == 0:  # start on the wave (no start-up transient)
            d.qpos[scene.robot_qpos], d.qvel[scene.robot_dof] = q, v
            mujoco.mj_forward(m, d)
        servo.command(q, v, a)
        for _ in range(sub):
            mujoco.mj_step(m, d)
        R.append(d.site_xmat[site].reshape(3, 3).copy())
    R = np.array(R)
    rel = np.einsum("ji,njk->nik", R[0], R)
    cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    return float(np.degrees(np.arccos(cos)).max())


def test_dynamics_feedforward_keeps_the_head_still_while_the_arm_waves():
    """Measured: 0.194 deg with ``inertia`` (the arm's centrifugal reaction on the trunk and
    neck servos nods the head), 0.005 deg with ``dynamics``."""
    still = _head_rotation_deg("dynamics")
    nod = _head_rotation_deg("inertia")
    assert still < 0.015
    assert nod > 0.1


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
