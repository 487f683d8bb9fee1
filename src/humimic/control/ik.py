"""Redundant differential IK of the humanoid with mink (QP solved by daqp) at the servo rate.

Ude & Atkeson: "The resulting 420 Hz Cartesian motion is finally transformed into the robot
motion using an inverse kinematics solver [...] The current version of the system also tries to
keep the position of the robot head with respect to the robot base constant. This is achieved
by exploiting the redundancy of the humanoid robot."

Each step solves, for the joint displacement ``dq`` over one servo period ``dt``::

    min  sum_i ||c_i (J_i dq + e_i)||^2 + damping ||dq||^2
    s.t. joint limits with a margin, |dq| <= v_max dt, arm-body distances >= margin

with the tasks (``e_i`` task errors, ``c_i`` costs):

* a position task per driven site (hand or elbow) towards the commanded point;
* a 6-D task holding the eyes' base (site ``eye_center``) at its start pose - the torso may
  still turn about its vertical axis while the neck turns back (B_TR vs B_HR), which leaves
  the eyes where they were (the waist and neck joints are on one vertical line);
* a posture task pulling every joint towards the rest pose (light on arms and head, heavier
  on the torso, stiff on legs and eyes - the eyes belong to gaze, the legs to nobody).

How it is solved: ``mink.build_ik`` assembles the QP from the tasks, the damping and the
collision limit (:class:`DisplacementCollisionLimit`); the joint and speed limits (mink's
``ConfigurationLimit`` and ``VelocityLimit``) go to daqp as simple bounds on ``dq`` rather than
as inequality rows, and collision rows out of range are dropped. That is the QP
``mink.solve_ik(..., "daqp", limits=...)`` solves, 3-4x faster (the test compares the two).

The IK runs on the robot alone (``models/db_humanoid.xml``, compiled with the scene's eye
spacing), whose world frame is the scene's (the robot is attached at the scene's origin), so
its frames are the scene's robot frames. Its state is the kinematic reference the servos track.
"""

from __future__ import annotations

import daqp
import mink
import mujoco
import numpy as np
from mink.limits.collision_avoidance_limit import compute_contact_normal_jacobian

from humimic.paths import MODELS_DIR
from humimic.world.names import EYE_JOINTS, ROBOT_JOINTS, TORSO_JOINTS

LEG_JOINTS = ("R_HFE", "R_HAA", "R_KFE", "L_HFE", "L_HAA", "L_KFE")
ARM_GEOMS = {"R": ("R_upper_arm", "R_forearm", "R_hand"),
             "L": ("L_upper_arm", "L_forearm", "L_hand")}
BODY_GEOMS = ("pelvis", "abdomen", "thorax", "neck", "skull", "R_thigh", "L_thigh")
#: Posture cost of the joints that tasks never need (per rad).
FROZEN_COST = 1.0
LEG_SPEED = 1.0  # rad/s
EYE_SPEED = 20.0  # rad/s
#: A joint closer than the IK's limit margin plus this (rad) to a limit sits on its limit band.
LIMIT_BAND_TOL = 2e-3


def on_limit_band(q: np.ndarray, ranges: np.ndarray, margin: float) -> np.ndarray:
    """Which joints (``q (..., n)``, ``ranges (n, 2)``) sit on the band the IK keeps them out
    of (within ``margin + LIMIT_BAND_TOL`` of a limit)."""
    band = margin + LIMIT_BAND_TOL
    return (q <= ranges[:, 0] + band) | (q >= ranges[:, 1] - band)


def build_robot_model(interocular: float = 0.07) -> mujoco.MjModel:
    """The robot alone, with the scene's eye spacing (frames identical to the scene's)."""
    spec = mujoco.MjSpec.from_file(str(MODELS_DIR / "db_humanoid.xml"))
    spec.body("L_eye").pos[1] = interocular / 2.0
    spec.body("R_eye").pos[1] = -interocular / 2.0
    return spec.compile()


def posture_costs(posture: float, torso: float) -> np.ndarray:
    """Per-joint posture cost in :data:`ROBOT_JOINTS` order."""
    cost = np.full(len(ROBOT_JOINTS), posture)
    for j, name in enumerate(ROBOT_JOINTS):
        if name in TORSO_JOINTS:
            cost[j] = torso
        elif name in LEG_JOINTS or name in EYE_JOINTS:
            cost[j] = FROZEN_COST
    return cost


def speed_limits(max_speed: float) -> dict[str, float]:
    """Per-joint speed limit (rad/s)."""
    out = {}
    for name in ROBOT_JOINTS:
        out[name] = (LEG_SPEED if name in LEG_JOINTS
                     else EYE_SPEED if name in EYE_JOINTS else max_speed)
    return out


#: The mink release whose ``CollisionAvoidanceLimit`` semantics :class:`DisplacementCollisionLimit`
#: replaces (checked by a test: re-read its ``compute_qp_inequalities`` before upgrading).
MINK_VERSION = "1.3"


class DisplacementCollisionLimit(mink.CollisionAvoidanceLimit):
    """mink's arm-body distance limit as a velocity damper in displacement units.

    For each geom pair closer than ``collision_detection_distance`` (distance ``d``, normal
    Jacobian row ``n``), the step must satisfy ``d + n dq >= d_min + (1 - gain)(d - d_min)``,
    i.e. ``-n dq <= gain (d - d_min)``: each step closes at most ``gain`` of the remaining
    margin, and a pair already inside the margin must move apart (by at most
    ``max_recovery`` per step).

    mink 1.3 bounds ``-n dq`` by ``gain (d - d_min) / dt`` (a velocity, ~360 times too loose
    at 420 Hz) and by 0 inside the margin, so a hand pulled into the chest slides in along
    the surface a little each step (to linearisation error) and never comes back out.

    Only mink's public interface is used (its pairs, distances and the public
    ``compute_contact_normal_jacobian``); the broad phase is a bounding-sphere test
    (``geom_rbound``), conservative, so the rows are those of testing every pair."""

    def __init__(self, *args, max_recovery: float = 0.002, **kwargs):
        super().__init__(*args, **kwargs)
        self.max_recovery = max_recovery
        pairs = np.array(self.geom_id_pairs, dtype=int).reshape(-1, 2)
        self._g1, self._g2 = pairs[:, 0], pairs[:, 1]
        self._reach = self.model.geom_rbound[self._g1] + self.model.geom_rbound[self._g2] \
            + self.collision_detection_distance
        nv = self.model.nv
        self._buf = (np.empty(6), np.empty(3), np.empty((3, nv)), np.empty((3, nv)))

    def compute_qp_inequalities(self, configuration, dt):
        model, data = self.model, configuration.data
        n = self.max_num_contacts
        G = np.zeros((n, model.nv))
        h = np.full(n, np.inf)
        distmax = self.collision_detection_distance
        fromto, normal, jac1, jac2 = self._buf
        gap = data.geom_xpos[self._g1] - data.geom_xpos[self._g2]
        near = np.einsum("ij,ij->i", gap, gap) <= self._reach * self._reach
        for idx in np.flatnonzero(near).tolist():
            g1, g2 = int(self._g1[idx]), int(self._g2[idx])
            dist = mujoco.mj_geomDistance(model, data, g1, g2, distmax, fromto)
            if abs(dist - distmax) < 1e-12:
                continue
            row = compute_contact_normal_jacobian(model, data, g1, g2, fromto, normal, jac1,
                                                  jac2)
            G[idx] = -row if dist >= 0 else row
            h[idx] = max(self.gain * (dist - self.minimum_distance_from_collisions),
                         -self.max_recovery)
        return mink.limits.Constraint(G=G, h=h)


def box_bounds(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, gain: float,
               v_max: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint-limit and velocity-limit constraints on ``dq`` fused into one box (hinge joints):
    ``max(-v dt, gain (lower - q)) <= dq <= min(v dt, gain (upper - q))`` - mink's
    ``ConfigurationLimit`` and ``VelocityLimit`` rows, as daqp's simple bounds. A joint already
    outside its band may move back only as fast as its speed limit allows."""
    lb = np.maximum(-v_max * dt, gain * (lower - q))
    ub = np.minimum(v_max * dt, gain * (upper - q))
    return np.minimum(lb, ub), np.maximum(ub, np.minimum(lb, ub))


def solve_qp(H: np.ndarray, c: np.ndarray, lb: np.ndarray, ub: np.ndarray, G: np.ndarray,
             h: np.ndarray) -> np.ndarray | None:
    """``argmin 1/2 x^T H x + c^T x`` s.t. ``lb <= x <= ub``, ``G x <= h`` with daqp (None if it
    fails)."""
    m = len(h)
    bupper = np.concatenate([ub, h])
    blower = np.concatenate([lb, np.full(m, -1e30)])
    sense = np.zeros(len(bupper), dtype=np.intc)
    x, _, exitflag, _ = daqp.solve(H, c, G, bupper, blower, sense)
    return x if exitflag > 0 else None


def clamp_into_limits(model: mujoco.MjModel, q: np.ndarray, margin: float) -> np.ndarray:
    """``q`` moved inside every joint range shrunk by ``margin`` (a feasible IK start)."""
    lo = model.jnt_range[:, 0] + margin
    hi = model.jnt_range[:, 1] - margin
    return np.clip(q, lo, np.maximum(lo, hi))


class MimicIK:
    """The IK problem for a set of driven sites; :meth:`step` once per servo tick.

    ``q0`` is the start (and rest) configuration in :data:`ROBOT_JOINTS` order. Targets are
    world-frame positions (the scene's world).
    """

    def __init__(self, model: mujoco.MjModel, q0: np.ndarray, sites: list[str], cfg,
                 dt: float, solver: str = "daqp"):
        self.model, self.dt, self.solver, self.damping = model, dt, solver, cfg.damping
        q0 = clamp_into_limits(model, np.asarray(q0, float), cfg.limit_margin * 1.01)
        self.configuration = mink.Configuration(model, q0)
        self.sites = list(sites)
        self.site_ids = np.array([model.site(s).id for s in self.sites])
        self.site_tasks = [mink.FrameTask(s, "site", position_cost=cfg.site_cost,
                                          orientation_cost=0.0) for s in self.sites]
        for task in self.site_tasks:
            task.set_target_from_configuration(self.configuration)
        self.head_task = mink.FrameTask("eye_center", "site", position_cost=cfg.head_cost,
                                        orientation_cost=cfg.head_cost)
        self.head_task.set_target_from_configuration(self.configuration)
        self.posture_task = mink.PostureTask(model, cost=posture_costs(cfg.posture_cost,
                                                                       cfg.torso_cost))
        self.posture_task.set_target(q0)
        self.tasks = [*self.site_tasks, self.head_task, self.posture_task]
        self.limits = [
            mink.ConfigurationLimit(model, min_distance_from_limits=cfg.limit_margin),
            mink.VelocityLimit(model, speed_limits(cfg.max_joint_speed)),
            DisplacementCollisionLimit(
                model, self.collision_pairs(), gain=0.5,
                minimum_distance_from_collisions=cfg.collision_margin,
                collision_detection_distance=cfg.collision_margin + 0.08),
        ]
        self.v = np.zeros(model.nv)
        self.failures = 0
        conf_limit, vel_limit, self.collision_limit = self.limits
        self._lower = conf_limit.lower.copy()
        self._upper = conf_limit.upper.copy()
        self._gain = conf_limit.gain
        self._vmax = np.zeros(model.nv)
        self._vmax[vel_limit.indices] = vel_limit.limit
        self._empty_G = np.zeros((0, model.nv))

    def solve(self) -> np.ndarray:
        """Joint velocity of the IK step at the current configuration (zero if the QP fails).

        The QP of ``mink.solve_ik(configuration, tasks, dt, "daqp", damping, limits)``, built
        by ``mink.build_ik``, with the joint and speed limits passed to daqp as simple bounds
        and the collision rows that are out of range dropped (see the module docstring)."""
        cfg = self.configuration
        qp = mink.build_ik(cfg, self.tasks, self.dt, self.damping, [self.collision_limit])
        lb, ub = box_bounds(cfg.q, self._lower, self._upper, self._gain, self._vmax, self.dt)
        keep = np.isfinite(qp.h)
        G, h = (qp.G[keep], qp.h[keep]) if keep.any() else (self._empty_G, qp.h[:0])
        dq = solve_qp(qp.P, qp.q, lb, ub, G, h)
        if dq is None:
            self.failures += 1
            return np.zeros(self.model.nv)
        return dq / self.dt

    @staticmethod
    def collision_pairs() -> list[tuple[list[str], list[str]]]:
        """Forearms and hands against the torso, head, pelvis and thighs; upper arms against the
        head; the arms against each other (an upper arm cannot reach the pelvis or thighs)."""
        pairs = []
        for side in ("R", "L"):
            upper, *lower = ARM_GEOMS[side]
            pairs += [(lower, list(BODY_GEOMS)), ([upper], ["neck", "skull"])]
        return [*pairs, (list(ARM_GEOMS["R"]), list(ARM_GEOMS["L"]))]

    @property
    def q(self) -> np.ndarray:
        return self.configuration.q

    def site_positions(self) -> np.ndarray:
        """``(n_sites, 3)`` world positions of the driven sites at the IK's configuration."""
        return self.configuration.data.site_xpos[self.site_ids]

    def step(self, p_world_targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Move each driven site towards its target (``(n_sites, 3)``, world); returns the new
        configuration and the joint velocity over the step. A QP failure holds the pose."""
        data = self.configuration.data
        for task, sid, p in zip(self.site_tasks, self.site_ids, p_world_targets, strict=True):
            # Target orientation = current one: with orientation cost 0 the SE(3) log's
            # translation part is then the plain position error. Written into the task's own
            # target (``set_target`` would copy it into a new SE3 every tick).
            target = task.transform_target_to_world.wxyz_xyz
            mujoco.mju_mat2Quat(target[:4], data.site_xmat[sid])
            target[4:] = p
        v = self.solve()
        self.configuration.integrate_inplace(v, self.dt)
        self.v = v
        return self.configuration.q, v
