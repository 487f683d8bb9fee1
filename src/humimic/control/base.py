"""The mobile base's controller: go to a planar pose at a limited speed (Sugiyama & Miura,
Sec. V-C: "The maximum speed of the robot movement is set to 0.4 m/s").

The base (``robot.base: planar``) has joints ``base_x``, ``base_y`` (m) and ``base_yaw`` (rad)
whose values are its pose in the robot's start frame -- the paper's R (x forward, y left, as
the robot stood at t = 0; with the robot at the scene's origin, also the world's x, y) -- and
velocity actuators (``ctrl`` = joint velocity).

:func:`base_velocity` is the control law, pure: a proportional approach that brakes so it can
stop at the goal within the acceleration limit (``v <= sqrt(2 a_max d)``), with the speed capped
at ``max_speed`` and changed by at most ``max_accel dt`` per step; the same for the heading.
:class:`BaseController` holds the target and the last command and writes the actuators of a
scene each servo tick.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BaseLimits:
    """Speed and acceleration limits (SI: m/s, m/s^2, rad/s, rad/s^2) and gains (1/s)."""

    max_speed: float = 0.4
    max_accel: float = 0.5
    max_yaw_rate: float = 0.8
    max_yaw_accel: float = 1.5
    gain: float = 4.0
    yaw_gain: float = 4.0


def wrap_angle(a: np.ndarray | float) -> np.ndarray | float:
    """Angle(s) wrapped into [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _limited(desired: np.ndarray, previous: np.ndarray, max_norm: float,
             max_change: float) -> np.ndarray:
    """``desired`` with its norm capped at ``max_norm`` and moved from ``previous`` by at most
    ``max_change``."""
    n = np.linalg.norm(desired)
    if n > max_norm:
        desired = desired * (max_norm / n)
    step = desired - previous
    s = np.linalg.norm(step)
    return previous + (step * (max_change / s) if s > max_change else step)


def base_velocity(pose: np.ndarray, target: np.ndarray, previous: np.ndarray, dt: float,
                  limits: BaseLimits = BaseLimits()) -> np.ndarray:
    """Velocity command ``(vx, vy, yaw_rate)`` in the base joints' frame (R) moving ``pose``
    ``(x, y, yaw)`` towards ``target`` ``(x, y, yaw)``; ``previous`` is the last command and
    ``dt`` the control period (s). ``|v| <= max_speed`` always."""
    pose, target, previous = (np.asarray(a, float) for a in (pose, target, previous))
    lim = limits
    e = target[:2] - pose[:2]
    d = float(np.linalg.norm(e))
    speed = min(lim.gain * d, np.sqrt(2.0 * lim.max_accel * d), lim.max_speed)
    v = _limited(e * (speed / d) if d > 1e-9 else np.zeros(2), previous[:2], lim.max_speed,
                 lim.max_accel * dt)
    e_yaw = float(wrap_angle(target[2] - pose[2]))
    rate = np.sign(e_yaw) * min(lim.yaw_gain * abs(e_yaw),
                                np.sqrt(2.0 * lim.max_yaw_accel * abs(e_yaw)), lim.max_yaw_rate)
    w = _limited(np.array([rate]), previous[2:], lim.max_yaw_rate, lim.max_yaw_accel * dt)
    return np.array([v[0], v[1], w[0]])


class BaseController:
    """Drives a scene's planar base to the latest target (call :meth:`step` every servo tick).

    ``target`` is ``(x, y, yaw)`` in the robot's start frame R (m, rad). :attr:`arrived` tells
    a command stage when the previous movement has finished (the paper issues a new command
    only then).
    """

    def __init__(self, scene, limits: BaseLimits = BaseLimits(), position_tolerance: float = 0.02,
                 yaw_tolerance: float = np.radians(1.0)):
        if len(scene.base_actuators) != 3:
            raise ValueError("the robot has no planar base: set robot.base: planar")
        self.scene, self.limits = scene, limits
        self.position_tolerance, self.yaw_tolerance = position_tolerance, yaw_tolerance
        self.command = np.zeros(3)
        self.target = self.pose.copy()

    @property
    def pose(self) -> np.ndarray:
        """Current ``(x, y, yaw)`` of the base in R."""
        return self.scene.data.qpos[self.scene.base_qpos].copy()

    @property
    def velocity(self) -> np.ndarray:
        """Current ``(vx, vy, yaw_rate)`` of the base in R."""
        return self.scene.data.qvel[self.scene.base_dof].copy()

    def set_target(self, x: float, y: float, yaw: float | None = None) -> None:
        """Go to ``(x, y)`` (m, R), turning to ``yaw`` (rad; default: keep the current)."""
        self.target = np.array([x, y, self.pose[2] if yaw is None else yaw], float)

    @property
    def arrived(self) -> bool:
        """At the target (within the tolerances) and stopped."""
        e = self.target - self.pose
        return (float(np.linalg.norm(e[:2])) <= self.position_tolerance
                and abs(float(wrap_angle(e[2]))) <= self.yaw_tolerance
                and float(np.linalg.norm(self.command)) < 1e-3)

    def step(self, dt: float) -> np.ndarray:
        """Compute and write the velocity command for the next ``dt`` seconds; returns it."""
        self.command = base_velocity(self.pose, self.target, self.command, dt, self.limits)
        self.scene.data.ctrl[self.scene.base_actuators] = self.command
        return self.command
