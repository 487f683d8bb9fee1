"""The wearer's head pose at any instant, for the stages that use it (arm EKF, commands).

Two sources with one interface: :class:`SlamHeadTrack` keeps the ``head_pose`` messages the
SLAM publishes (:class:`~humimic.messages.HeadPose`, in the paper's W) and interpolates between
them; :class:`OracleHeadTrack` reads the ground truth of the head camera (the scenario option
``head_pose: oracle``, which separates the consumer's errors from the SLAM's). A consumer asks
:meth:`HeadTrack.ready_until` before :meth:`HeadTrack.at`: a SLAM estimate for time ``t``
arrives at its ready time, so measurements wait until the head is known at theirs.
"""

from __future__ import annotations

import bisect
from collections import deque
from dataclasses import dataclass

import numpy as np

from humimic.estimation.ekf.arm_model import qexp, qlog, qmul, rotation


@dataclass(frozen=True)
class HeadState:
    """The head camera (frame I) in W at one instant."""

    p_W: np.ndarray
    R_W_I: np.ndarray
    w_I: np.ndarray
    """Angular velocity in I (rad/s)."""


class HeadTrack:
    def ready_until(self) -> float:
        """The latest time (s) at which the head is known."""
        raise NotImplementedError

    def at(self, t: float) -> HeadState:
        raise NotImplementedError


class OracleHeadTrack(HeadTrack):
    """Ground truth of the head camera (``gt.pose("headcam", "W")``) at the nearest tick."""

    def __init__(self, gt):
        T = gt.pose("headcam", "W")
        self._p, self._R = T[:, :3, 3], T[:, :3, :3]
        self._w = gt.angular_velocity("headcam", "site")
        self._t0 = float(gt.t[0])
        self._rate = (len(gt.t) - 1) / float(gt.t[-1] - gt.t[0]) if len(gt.t) > 1 else 1.0

    def ready_until(self) -> float:
        return float("inf")

    def at(self, t: float) -> HeadState:
        k = min(max(int(round((t - self._t0) * self._rate)), 0), len(self._p) - 1)
        return HeadState(self._p[k], self._R[k], self._w[k])


class SlamHeadTrack(HeadTrack):
    """``head_pose`` messages kept for ``horizon`` seconds and interpolated (slerp for the
    orientation, linear for position and rate); held beyond the last one."""

    def __init__(self, horizon: float = 2.0):
        self.horizon = horizon
        self._t: deque[float] = deque()
        self._v: deque = deque()

    def add(self, t: float, pose) -> None:
        """A :class:`~humimic.messages.HeadPose` sampled at ``t`` (s)."""
        if self._t and t <= self._t[-1]:
            return
        self._t.append(t)
        q = np.asarray(pose.q_W_I, float)
        self._v.append((HeadState(np.asarray(pose.p_W, float), rotation(q),
                                  np.asarray(pose.w_I, float)), q / np.linalg.norm(q)))
        while len(self._t) > 2 and self._t[1] < t - self.horizon:
            self._t.popleft()
            self._v.popleft()

    def ready_until(self) -> float:
        return self._t[-1] if self._t else float("-inf")

    def at(self, t: float) -> HeadState:
        if not self._t:
            raise LookupError("no head pose yet")
        ts = self._t
        i = bisect.bisect_right(ts, t)
        if i == 0:
            return self._v[0][0]
        if i == len(ts):
            return self._v[-1][0]
        (a, qa), (b, qb) = self._v[i - 1], self._v[i]
        s = (t - ts[i - 1]) / (ts[i] - ts[i - 1])
        qac = (qa[0], -qa[1], -qa[2], -qa[3])
        q = qmul(qa, qexp(s * qlog(qmul(qac, qb))))  # slerp
        return HeadState((1 - s) * a.p_W + s * b.p_W, rotation(q), (1 - s) * a.w_I + s * b.w_I)
