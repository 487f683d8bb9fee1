"""A smooth avatar joint trajectory with analytic velocities and accelerations.

Sampled configurations are fitted with interpolating B-splines (degree 5 by default, so
position, velocity and acceleration are C4/C3/C2 continuous):

* slides and hinges: one scalar spline each; ``qvel = q'``, ``qacc = q''``;
* ball joints: a spline through each quaternion component after making the samples
  hemisphere-continuous (``q_k . q_{k-1} >= 0``); the spline ``r(t)`` is normalised,
  ``q = r / |r|``, with the exact derivatives of the normalisation
  ``q' = (r' - q n') / n``, ``q'' = (r'' - 2 q' n' - q n'') / n`` (``n = |r|``,
  ``n' = q . r'``, ``n'' = (|r'|^2 + r . r'' - n'^2) / n``), and MuJoCo's local angular
  velocity and acceleration ``w = 2 vec(conj(q) (x) q')``, ``dw/dt = 2 vec(conj(q) (x) q'')``
  (the ``conj(q') (x) q'`` term of the latter is real).

Outside ``[t0, t1]`` the trajectory holds its end configuration with zero velocity and
acceleration.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import make_interp_spline

from humimic.motion import quat
from humimic.motion.avatar import BALL_JOINTS, DOF_SLICES, NQ, NV, QPOS_SLICES, SCALAR_JOINTS
from humimic.motion.context import HumanMotion

_BALL_Q = np.array([QPOS_SLICES[j].start for j in BALL_JOINTS])
_BALL_V = np.array([DOF_SLICES[j].start for j in BALL_JOINTS])
_SCALAR_Q = np.array([QPOS_SLICES[j].start for j in SCALAR_JOINTS])
_SCALAR_V = np.array([DOF_SLICES[j].start for j in SCALAR_JOINTS])


def normalized_quaternion_derivatives(r: np.ndarray, dr: np.ndarray, ddr: np.ndarray
                                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``q, q', q''`` of ``q = r / |r|`` given ``r, r', r''`` (..., 4)."""
    n = np.linalg.norm(r, axis=-1, keepdims=True)
    q = r / n
    dn = np.sum(q * dr, axis=-1, keepdims=True)
    dq = (dr - q * dn) / n
    ddn = (np.sum(dr * dr, axis=-1, keepdims=True) + np.sum(r * ddr, axis=-1, keepdims=True)
           - dn * dn) / n
    ddq = (ddr - 2.0 * dq * dn - q * ddn) / n
    return q, dq, ddq


def local_angular(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame angular velocity and acceleration ``2 vec(conj(q) (x) q')``, ``... q''``."""
    qc = quat.conj(q)
    return 2.0 * quat.mul(qc, dq)[..., 1:], 2.0 * quat.mul(qc, ddq)[..., 1:]


class JointTrajectory:
    """Avatar trajectory ``t -> (qpos (N, 51), qvel (N, 40), qacc (N, 40))``."""

    nq = NQ
    nv = NV

    def __init__(self, times: np.ndarray, qpos: np.ndarray, degree: int = 5):
        times = np.asarray(times, float)
        qpos = np.array(qpos, float)
        if qpos.shape != (len(times), NQ):
            raise ValueError(f"qpos must be (N, {NQ}), got {qpos.shape}")
        if np.any(np.diff(times) <= 0):
            raise ValueError("sample times must increase")
        k = min(degree, len(times) - 1)
        for j in BALL_JOINTS:
            s = QPOS_SLICES[j]
            qpos[:, s] = quat.hemisphere_continuous(quat.normalize(qpos[:, s]))
        self.times = times
        self.t0, self.t1 = float(times[0]), float(times[-1])
        self.degree = k
        self._spline = make_interp_spline(times, qpos, k=k, axis=0) if k > 0 else None
        self._q_end = (qpos[0].copy(), qpos[-1].copy())  # not views: qpos is not kept

    @classmethod
    def from_motion(cls, motion: HumanMotion, duration: float, rate: float | None = None,
                    degree: int = 5) -> JointTrajectory:
        """Sample ``motion`` on ``[0, duration]`` (plus a few samples' margin) at ``rate`` Hz
        (default: the motion's own ``sample_rate``) and fit."""
        rate = rate or motion.sample_rate
        n = int(np.ceil(duration * rate)) + 4
        t = np.arange(n) / rate
        return cls(t, motion.sample(t), degree)

    def evaluate(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``qpos (N, 51)``, ``qvel (N, 40)``, ``qacc (N, 40)`` at times ``t``."""
        t = np.atleast_1d(np.asarray(t, float))
        n = len(t)
        qpos, qvel, qacc = np.empty((n, NQ)), np.zeros((n, NV)), np.zeros((n, NV))
        if self._spline is None:
            qpos[:] = self._q_end[0]
            return qpos, qvel, qacc
        tc = np.clip(t, self.t0, self.t1)
        inside = (t >= self.t0) & (t <= self.t1)
        r = self._spline(tc)
        dr = self._spline(tc, 1) * inside[:, None]
        ddr = self._spline(tc, 2) * inside[:, None]
        qpos[:, _SCALAR_Q] = r[:, _SCALAR_Q]
        qvel[:, _SCALAR_V] = dr[:, _SCALAR_Q]
        qacc[:, _SCALAR_V] = ddr[:, _SCALAR_Q]
        iq = _BALL_Q[:, None] + np.arange(4)  # (B, 4) qpos columns of each ball
        q, dq, ddq = normalized_quaternion_derivatives(r[:, iq], dr[:, iq], ddr[:, iq])
        w, dw = local_angular(q, dq, ddq)
        qpos[:, iq] = q
        iv = _BALL_V[:, None] + np.arange(3)
        qvel[:, iv] = w
        qacc[:, iv] = dw
        return qpos, qvel, qacc

    def qpos(self, t: np.ndarray | float) -> np.ndarray:
        return self.evaluate(t)[0]

    def qvel(self, t: np.ndarray | float) -> np.ndarray:
        return self.evaluate(t)[1]

    def qacc(self, t: np.ndarray | float) -> np.ndarray:
        return self.evaluate(t)[2]


class WindowedTrajectory:
    """:meth:`JointTrajectory.from_motion` over a long run, fitted a window at a time so its
    memory does not grow with the duration (a whole-run spline holds ~100 kB per second).

    Window ``i`` covers ``[i W, (i + 1) W)`` and is an interpolating spline through the motion's
    samples on the same grid as the whole-run fit, ``margin`` seconds wider on each side: the
    B-spline's dependence on far samples decays geometrically, so inside a window it matches
    the whole-run fit to rounding. The two most recent windows are kept. A run no longer than
    one window is a single :class:`JointTrajectory`, exactly the whole-run fit.
    """

    nq = NQ
    nv = NV

    def __init__(self, motion: HumanMotion, duration: float, window: float = 30.0,
                 margin: float = 2.0, degree: int = 5):
        self.motion, self.duration, self.degree = motion, float(duration), degree
        self.window, self.margin = float(window), float(margin)
        self.rate = float(motion.sample_rate)
        self._fits: dict[int, JointTrajectory] = {}
        self._single = (JointTrajectory.from_motion(motion, duration, degree=degree)
                        if duration <= window + margin else None)

    def _fit(self, i: int) -> JointTrajectory:
        fit = self._fits.get(i)
        if fit is None:
            n_all = int(np.ceil(self.duration * self.rate)) + 4  # from_motion's sample grid
            lo = max(0, int(np.floor((i * self.window - self.margin) * self.rate)))
            hi = min(n_all, int(np.ceil(((i + 1) * self.window + self.margin) * self.rate)) + 1)
            t = np.arange(lo, hi) / self.rate
            fit = JointTrajectory(t, self.motion.sample(t), self.degree)
            if len(self._fits) >= 2:
                self._fits.pop(next(iter(self._fits)))
            self._fits[i] = fit
        return fit

    def evaluate(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self._single is not None:
            return self._single.evaluate(t)
        t = np.atleast_1d(np.asarray(t, float))
        qpos, qvel, qacc = np.empty((len(t), NQ)), np.empty((len(t), NV)), np.empty((len(t), NV))
        win = np.clip(np.floor(t / self.window), 0, None).astype(int)
        for i in np.unique(win).tolist():
            sel = win == i
            qpos[sel], qvel[sel], qacc[sel] = self._fit(i).evaluate(t[sel])
        return qpos, qvel, qacc
