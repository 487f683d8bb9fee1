"""Ground truth of the person's motion at every physics step: site kinematics and true sensors.

For each time the avatar's ``qpos/qvel/qacc`` (from :class:`JointTrajectory`, analytic) are set
in a private ``MjData`` of the scene's model, ``mj_inverse`` computes positions, velocities and
the noise-free sensors (MuJoCo's accelerometer is the specific force ``R^T (a - g)``), and
``mj_rnePostConstraint`` the bodies' spatial accelerations ``cacc``. Site velocity and
acceleration are then what ``mj_objectVelocity`` / ``mj_objectAcceleration`` (``flg_local=0``)
return, evaluated in one vectorised pass: with ``c`` the subtree COM of the body's root,
``v = v_c + w x (p - c)``, ``a = a_c + dw x (p - c) + w x v``. ``cacc`` contains ``-g`` (the
world body accelerates upwards), so ``a + g`` is the true kinematic acceleration.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from humimic.motion.context import HumanMotion
from humimic.motion.trajectory import JointTrajectory
from humimic.world.names import HUMAN_PREFIX, HUMAN_TARGETS
from humimic.world.scene import Scene

#: Targets whose orientation is recorded (the worn IMUs and the head camera's frame I).
ORIENTED_TARGETS = ("head_imu", "wiimote", "headcam")
#: Frames ground truth can be expressed in: the scene's world, the robot base (its pose at
#: t = 0), and the paper's W (Sugiyama & Miura, Fig. 5; see :mod:`humimic.world.frames`).
FRAMES = ("world", "base", "W")
SENSORS = ("head_acc", "head_gyro", "head_quat", "wiimote_acc", "wiimote_gyro")


@dataclass(frozen=True)
class GroundTruth:
    """True avatar motion, indexed by time sample (world frame unless ``_base``)."""

    t: np.ndarray
    """(N,) sample times (s)."""
    qpos: np.ndarray
    """(N, 51) avatar configuration (write into ``scene.data.qpos[scene.human_qpos]``)."""
    qvel: np.ndarray
    """(N, 40)"""
    targets: tuple[str, ...]
    """Target names (keys of :data:`humimic.world.names.HUMAN_TARGETS`), axis 1 below."""
    pos: np.ndarray
    """(N, K, 3) site positions, world (m)."""
    vel: np.ndarray
    """(N, K, 3) site linear velocities, world (m/s)."""
    acc: np.ndarray
    """(N, K, 3) site linear accelerations, world, gravity excluded (m/s^2)."""
    angvel: np.ndarray
    """(N, K, 3) angular velocities of the sites' bodies, world axes (rad/s)."""
    R_imu: np.ndarray
    """(N, len(ORIENTED_TARGETS), 3, 3) world <- site rotations of the oriented sites."""
    sensors: dict[str, np.ndarray]
    """Noise-free sensor readings by name (``head_acc`` ... ), (N, dim), site frames."""
    T_world_base: np.ndarray
    """4x4 robot-base pose at t = 0 (the base frame of every ``_base`` accessor)."""
    T_world_W: np.ndarray
    """4x4 pose of the paper's frame W in the world (:func:`humimic.world.frames.paper_frame`)."""
    gravity: np.ndarray
    """(3,) gravity in the world (m/s^2)."""

    def _k(self, name: str) -> int:
        try:
            return self.targets.index(name)
        except ValueError:
            raise KeyError(f"unknown target {name!r}; targets are {self.targets}") from None

    def index_of(self, t: float | np.ndarray) -> int | np.ndarray:
        """Index of the sample nearest ``t`` (raises if ``t`` is outside the samples)."""
        ta = np.asarray(t, float)
        if np.any(ta < self.t[0] - 1e-9) or np.any(ta > self.t[-1] + 1e-9):
            raise ValueError(f"time {t} outside [{self.t[0]}, {self.t[-1]}]")
        i = np.clip(np.searchsorted(self.t, ta), 1, len(self.t) - 1)
        i = np.where(np.abs(self.t[i - 1] - ta) <= np.abs(self.t[i] - ta), i - 1, i)
        return int(i) if np.ndim(i) == 0 else i

    # ---- world frame ----
    def p_world(self, name: str) -> np.ndarray:
        return self.pos[:, self._k(name)]

    def v_world(self, name: str) -> np.ndarray:
        return self.vel[:, self._k(name)]

    def a_world(self, name: str) -> np.ndarray:
        return self.acc[:, self._k(name)]

    def R_world(self, name: str) -> np.ndarray:
        """(N, 3, 3) orientation of an oriented site (:data:`ORIENTED_TARGETS`)."""
        return self.R_imu[:, ORIENTED_TARGETS.index(name)]

    # ---- robot base frame (T_world_base is constant) ----
    def p_base(self, name: str) -> np.ndarray:
        R, p = self.T_world_base[:3, :3], self.T_world_base[:3, 3]
        return (self.p_world(name) - p) @ R

    def v_base(self, name: str) -> np.ndarray:
        return self.v_world(name) @ self.T_world_base[:3, :3]

    def a_base(self, name: str) -> np.ndarray:
        return self.a_world(name) @ self.T_world_base[:3, :3]

    def R_base(self, name: str) -> np.ndarray:
        return self.T_world_base[:3, :3].T @ self.R_world(name)

    def sensor(self, name: str) -> np.ndarray:
        return self.sensors[name]

    # ---- any frame: ``frame`` is ``world``, ``base`` or ``W`` ----
    def T_world_frame(self, frame: str) -> np.ndarray:
        """4x4 pose of ``frame`` in the world."""
        if frame not in FRAMES:
            raise KeyError(f"unknown frame {frame!r}; frames are {FRAMES}")
        return {"world": np.eye(4), "base": self.T_world_base, "W": self.T_world_W}[frame]

    def position(self, name: str, frame: str = "world") -> np.ndarray:
        """(N, 3) site position in ``frame`` (m)."""
        T = self.T_world_frame(frame)
        return (self.p_world(name) - T[:3, 3]) @ T[:3, :3]

    def velocity(self, name: str, frame: str = "world") -> np.ndarray:
        """(N, 3) site linear velocity (m/s), ``frame`` axes."""
        return self.v_world(name) @ self.T_world_frame(frame)[:3, :3]

    def acceleration(self, name: str, frame: str = "world") -> np.ndarray:
        """(N, 3) site linear acceleration, gravity excluded (m/s^2), ``frame`` axes."""
        return self.a_world(name) @ self.T_world_frame(frame)[:3, :3]

    def angular_velocity(self, name: str, frame: str = "world") -> np.ndarray:
        """(N, 3) angular velocity (rad/s) in ``frame`` axes, or ``"site"`` (what a gyro on the
        site reads; oriented targets only)."""
        w = self.angvel[:, self._k(name)]
        if frame == "site":
            return np.einsum("nji,nj->ni", self.R_world(name), w)
        return w @ self.T_world_frame(frame)[:3, :3]

    def rotation(self, name: str, frame: str = "world") -> np.ndarray:
        """(N, 3, 3) ``R_frame_site`` of an oriented target (:data:`ORIENTED_TARGETS`)."""
        return self.T_world_frame(frame)[:3, :3].T @ self.R_world(name)

    def pose(self, name: str, frame: str = "world") -> np.ndarray:
        """(N, 4, 4) ``T_frame_site`` of an oriented target (:data:`ORIENTED_TARGETS`):
        ``pose("headcam", "W")`` is the paper's interface pose (p_I, q_I) in W."""
        T = np.zeros((len(self.t), 4, 4))
        T[:, :3, :3] = self.rotation(name, frame)
        T[:, :3, 3] = self.position(name, frame)
        T[:, 3, 3] = 1.0
        return T

    def specific_force(self, name: str) -> np.ndarray:
        """(N, 3) ``R_world_site^T (a - g)`` in the site frame (m/s^2): what an accelerometer
        on an oriented target reads (at rest: 9.81 m/s^2 along the site's up)."""
        return np.einsum("nji,nj->ni", self.R_world(name), self.a_world(name) - self.gravity)

    def inertial(self, which: str) -> tuple[np.ndarray, np.ndarray]:
        """True ``(specific force (N, 3) m/s^2, angular velocity (N, 3) rad/s)`` in the site
        frame of ``head_imu`` or ``wiimote`` (what a noise-free IMU there reads)."""
        prefix = {"head_imu": "head", "wiimote": "wiimote"}[which]
        return self.sensors[f"{prefix}_acc"], self.sensors[f"{prefix}_gyro"]


#: Samples processed per chunk (bounds the temporaries; the result is ~1.1 kB per sample).
CHUNK = 4096


def _chunk(m: mujoco.MjModel, d: mujoco.MjData, sq: slice, sv: slice, sites: np.ndarray,
           oriented: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, qacc: np.ndarray):
    """Site positions, velocities, accelerations (world, gravity removed), IMU-site rotations
    and sensor data for one chunk of samples."""
    n = len(qpos)
    bodies = m.site_bodyid[sites]
    roots = m.body_rootid[bodies]
    p = np.empty((n, len(sites), 3))
    xmat = np.empty((n, len(oriented), 9))
    cvel = np.empty((n, len(sites), 6))
    cacc = np.empty((n, len(sites), 6))
    com = np.empty((n, len(sites), 3))
    sensordata = np.empty((n, m.nsensordata))
    take = np.take
    for i in range(n):
        d.qpos[sq] = qpos[i]
        d.qvel[sv] = qvel[i]
        d.qacc[sv] = qacc[i]
        mujoco.mj_inverse(m, d)
        mujoco.mj_rnePostConstraint(m, d)
        take(d.site_xpos, sites, axis=0, out=p[i])
        take(d.site_xmat, oriented, axis=0, out=xmat[i])
        take(d.cvel, bodies, axis=0, out=cvel[i])
        take(d.cacc, bodies, axis=0, out=cacc[i])
        take(d.subtree_com, roots, axis=0, out=com[i])
        sensordata[i] = d.sensordata
    # mj_objectVelocity / mj_objectAcceleration (flg_local = 0), vectorised
    r = p - com
    v = cvel[..., 3:] + np.cross(cvel[..., :3], r)
    a = cacc[..., 3:] + np.cross(cacc[..., :3], r) + np.cross(cvel[..., :3], v) + m.opt.gravity
    return p, v, a, cvel[..., :3], xmat.reshape(n, len(oriented), 3, 3), sensordata


class GroundTruthSampler:
    """Evaluates the ground truth at any times, reusing one private ``MjData`` (``scene.data``
    is not touched): the one implementation behind :func:`compute_ground_truth` and
    :class:`humimic.motion.lazy_ground_truth.LazyGroundTruth`."""

    def __init__(self, scene: Scene, trajectory: JointTrajectory):
        self.scene, self.trajectory = scene, trajectory
        m = self.model = scene.model
        self.data = mujoco.MjData(m)
        self.data.qpos[:] = scene.data.qpos  # the robot's pose does not affect the avatar's
        self.targets = tuple(HUMAN_TARGETS)
        self.sites = np.array([scene.human_site(k) for k in self.targets])
        self.oriented = self.sites[[self.targets.index(k) for k in ORIENTED_TARGETS]]
        self.sensor_cols = {}
        for name in SENSORS:
            sid = m.sensor(HUMAN_PREFIX + name).id
            adr = int(m.sensor_adr[sid])
            self.sensor_cols[name] = slice(adr, adr + int(m.sensor_dim[sid]))

    def sample(self, times: np.ndarray) -> GroundTruth:
        """Ground truth at ``times`` (s), evaluated in chunks of :data:`CHUNK` samples."""
        times = np.asarray(times, float)
        m, n, traj, scene = self.model, len(times), self.trajectory, self.scene
        qpos, qvel = np.empty((n, traj.nq)), np.empty((n, traj.nv))
        pos, vel, acc, angvel = (np.empty((n, len(self.sites), 3)) for _ in range(4))
        R_imu = np.empty((n, len(self.oriented), 3, 3))
        sensordata = np.empty((n, m.nsensordata))
        for start in range(0, n, CHUNK):
            c = slice(start, min(n, start + CHUNK))
            qpos[c], qvel[c], qacc = traj.evaluate(times[c])
            pos[c], vel[c], acc[c], angvel[c], R_imu[c], sensordata[c] = _chunk(
                m, self.data, scene.human_qpos, scene.human_dof, self.sites, self.oriented,
                qpos[c], qvel[c], qacc)
        sensors = {name: sensordata[:, cols].copy() for name, cols in self.sensor_cols.items()}
        return GroundTruth(t=times.copy(), qpos=qpos, qvel=qvel, targets=self.targets, pos=pos,
                           vel=vel, acc=acc, angvel=angvel, R_imu=R_imu, sensors=sensors,
                           T_world_base=scene.T_world_base.copy(),
                           T_world_W=scene.T_world_W.copy(), gravity=m.opt.gravity.copy())


def compute_ground_truth(scene: Scene, trajectory: JointTrajectory | HumanMotion,
                         times: np.ndarray) -> GroundTruth:
    """Ground truth at ``times`` (s) for the avatar following ``trajectory`` in ``scene``.

    A :class:`HumanMotion` is first fitted with :meth:`JointTrajectory.from_motion` over
    ``[0, max(times)]``. Uses its own ``MjData``; ``scene.data`` is not touched. Holds every
    sample in memory (~1.9 kB each): a whole run uses
    :class:`~humimic.motion.lazy_ground_truth.LazyGroundTruth` instead.
    """
    times = np.asarray(times, float)
    if not isinstance(trajectory, JointTrajectory):
        trajectory = JointTrajectory.from_motion(trajectory, float(np.max(times)))
    return GroundTruthSampler(scene, trajectory).sample(times)
