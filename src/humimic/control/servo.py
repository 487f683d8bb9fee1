"""Joint targets for MuJoCo position servos, with velocity and inverse-dynamics feed-forward.

A MuJoCo ``position`` actuator with ``dampratio`` applies ``f = kp (ctrl - q) - kv qdot``, and
the joint adds its passive damping ``-b qdot``. Commanding only the IK's ``q_d`` leaves a lag of
about ``(kv + b) / kp`` behind a moving target (tens of ms on the shoulders). Choosing

    ctrl = q_d + ((kv + b) qdot_d + tau_ff) / kp

turns the servo into ``f = kp (q_d - q) + kv (qdot_d - qdot) + b (qdot_d - qdot) - b qdot_d
+ ...``, i.e. a PD about the moving reference plus the feed-forward torque ``tau_ff`` - the
"control schemes based on inverse dynamics" the paper's Cartesian accelerations make possible.
Gravity is compensated by the model (``gravcomp``); ``servo.feedforward`` chooses ``tau_ff``:

* ``dynamics``: the rigid-body inverse dynamics without gravity,
  ``tau_ff = M(q) qdd_d + c(q, qdot)`` (``c``: the Coriolis and centrifugal forces, MuJoCo's
  ``qfrc_bias - qfrc_gravcomp`` at the current state). ``c`` matters most on the joints that
  do not move: a waving arm's centrifugal reaction on the trunk and neck servos (kp 4000 and
  300 Nm/rad) nodded the head by 0.32 deg while the arm mimicked a jerky estimate; with ``c``
  fed forward 0.04 deg on the same joint references (``docs/ude_control_notes.md``, "The
  head nods with the arm");
* ``inertia``: ``tau_ff = M(q) qdd_d`` only (the inertial lag; what ``dynamics`` was before).
"""

from __future__ import annotations

import mujoco
import numpy as np


def servo_command(q_d: np.ndarray, qdot_d: np.ndarray, tau_ff: np.ndarray | float,
                  kp: np.ndarray, kv: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Position-servo targets that realise ``q_d, qdot_d`` and add ``tau_ff`` (see module)."""
    return q_d + ((kv + b) * qdot_d + tau_ff) / kp


class ServoGains:
    """The robot actuators' ``kp``, ``kv`` and joint damping ``b``, read from a compiled model
    (``kv`` is what MuJoCo computed from ``dampratio``)."""

    def __init__(self, model: mujoco.MjModel, actuators: np.ndarray, dofs: np.ndarray):
        self.kp = model.actuator_gainprm[actuators, 0].copy()
        self.kv = -model.actuator_biasprm[actuators, 2].copy()
        self.b = model.dof_damping[dofs].copy()


class Servo:
    """Writes the robot's actuator targets each servo tick (in a scene's ``MjData``)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, actuators: np.ndarray,
                 dofs: np.ndarray, feedforward: str):
        self.model, self.data = model, data
        self.actuators, self.dofs = np.asarray(actuators), np.asarray(dofs)
        self.gains = ServoGains(model, self.actuators, self.dofs)
        self.feedforward = feedforward
        self._qacc = np.zeros(model.nv)
        self._tau = np.zeros(model.nv)

    def inverse_dynamics(self, qdd_d: np.ndarray, velocity_terms: bool = True) -> np.ndarray:
        """``M(q) qdd_d + c(q, qdot)`` at the scene's current state (robot joints): the
        inverse dynamics without gravity (``gravcomp``); ``c`` (Coriolis and centrifugal)
        only with ``velocity_terms``. From the last physics step's ``qM`` and ``qfrc_bias``
        (computed at its start: 1/840 s old)."""
        d = self.data
        self._qacc[self.dofs] = qdd_d
        mujoco.mj_mulM(self.model, d, self._tau, self._qacc)
        tau = self._tau[self.dofs]
        if velocity_terms:
            tau += d.qfrc_bias[self.dofs] - d.qfrc_gravcomp[self.dofs]
        return tau

    def command(self, q_d: np.ndarray, qdot_d: np.ndarray, qdd_d: np.ndarray) -> np.ndarray:
        g = self.gains
        if self.feedforward == "none":
            ctrl = q_d.copy()
        elif self.feedforward == "velocity":
            ctrl = servo_command(q_d, qdot_d, 0.0, g.kp, g.kv, g.b)
        else:
            tau = self.inverse_dynamics(qdd_d, velocity_terms=self.feedforward == "dynamics")
            ctrl = servo_command(q_d, qdot_d, tau, g.kp, g.kv, g.b)
        self.data.ctrl[self.actuators] = ctrl
        return ctrl
