"""A whole run's inertial readings evaluated a block of samples at a time: memory stays flat in
the run's duration.

:func:`~humimic.sensors.inertial.simulate_inertial` and
:func:`~humimic.sensors.inertial.simulate_orientation` draw every sample's noise at once (ten
minutes of the head IMU at 180 Hz with its orientation output: 36 MB). :func:`stream_inertial`
gives the same readings, bit for bit, as :class:`~humimic.sensors.inertial.InertialSamples`
whose per-sample fields are :class:`~humimic.motion.lazy_ground_truth.LazyArray`: a first pass
draws the noise block by block in the eager functions' order, keeping only each block's
generator state and the running states of the bias random walks (a cumulative sum) and the
Gauss-Markov filters (their ``lfilter`` state); a block's readings are then recomputed on
demand from those and the ground truth at its samples (the last block is cached: the
simulation reads them in order).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from humimic.motion.lazy_ground_truth import LazyArray
from humimic.sensors.inertial import (
    InertialSamples,
    OrientationSamples,
    orientation_noise,
    perturb_orientation,
    sample_dt,
    walk_and_white,
)

#: Samples per block (a block's readings: ~0.6 MB).
BLOCK = 2048


@dataclass
class _Normals:
    """One ``standard_normal((n, d))`` draw of a generator, replayable a block at a time."""

    d: int
    states: list[dict]
    bit_generator: type

    @classmethod
    def draw(cls, rng: np.random.Generator, n: int, d: int, each: Callable | None = None
             ) -> _Normals:
        """Advance ``rng`` past the draw, block by block, calling ``each(block_index,
        normals)`` on every block (to carry a running state forward)."""
        states = []
        for b, s in enumerate(range(0, n, BLOCK)):
            states.append(copy.deepcopy(rng.bit_generator.state))
            z = rng.standard_normal((min(BLOCK, n - s), d))
            if each is not None:
                each(b, z)
        return cls(d, states, type(rng.bit_generator))

    def block(self, b: int, n: int) -> np.ndarray:
        """The draw's rows of block ``b`` (``n`` rows)."""
        bits = self.bit_generator()
        bits.state = self.states[b]
        return np.random.Generator(bits).standard_normal((n, self.d))


class _Axis:
    """Noise of one three-axis reading (accelerometer or gyroscope): white noise and a bias
    random walk, with the walk's value before each block."""

    def __init__(self, rng, t: np.ndarray, density: float, walk: float):
        self.t, self.density, self.walk = t, density, walk
        n = len(t)
        self.white = _Normals.draw(rng, n, 3)
        self.bias_before = [np.zeros(3)]

        def carry(b, z):
            _, bias = self._bias(b, z)
            self.bias_before.append(bias[-1])

        self.steps = _Normals.draw(rng, n, 3, carry)

    def _bias(self, b: int, step_normals: np.ndarray):
        s = b * BLOCK
        dt = sample_dt(self.t, s, s + len(step_normals))
        return dt, walk_and_white(None, dt, self.density, self.walk, None, step_normals,
                                  s == 0, self.bias_before[b])[1]

    def block(self, b: int, true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = len(true)
        s = b * BLOCK
        return walk_and_white(true, sample_dt(self.t, s, s + n), self.density, self.walk,
                              self.white.block(b, n), self.steps.block(b, n), s == 0,
                              self.bias_before[b])


class _Orientation:
    """Yaw/pitch/roll errors of an orientation output, as
    :func:`~humimic.sensors.inertial.orientation_errors` draws them (the Gauss-Markov drive,
    then its first sample from the stationary law, then the white noise)."""

    def __init__(self, rng, t: np.ndarray, cfg):
        n = len(t)
        dt = float(np.mean(np.diff(t))) if n > 1 else 1.0 / cfg.rate
        self.sigma, tau, self.res = orientation_noise(cfg)
        self.phi = np.exp(-dt / np.asarray(tau, float))
        self.drive = _Normals.draw(rng, n, 3)
        self.first = rng.standard_normal(3) * self.sigma if n else None
        self.white = _Normals.draw(rng, n, 3)
        self.zi = [np.zeros((3, 1))]  # the filters' states before each block
        for b, s in enumerate(range(0, n, BLOCK)):
            self.zi.append(self._slow(b, min(BLOCK, n - s))[1])

    def _slow(self, b: int, n: int) -> tuple[np.ndarray, np.ndarray]:
        w = self.drive.block(b, n) * self.sigma * np.sqrt(1.0 - self.phi**2)
        if b == 0:
            w[0] = self.first
        out, zf = np.empty_like(w), np.empty((3, 1))
        for i in range(3):
            out[:, i], zf[i] = lfilter([1.0], [1.0, -self.phi[i]], w[:, i], zi=self.zi[b][i])
        return out, zf

    def block(self, b: int, n: int) -> np.ndarray:
        return self._slow(b, n)[0] + self.white.block(b, n) * self.res


def stream_inertial(t: np.ndarray, true_rows: Callable[[np.ndarray], tuple], cfg,
                    rng: np.random.Generator, orientation: bool) -> InertialSamples:
    """Readings at ``t`` of a sensor configured by ``cfg`` whose truth at sample indices
    ``idx`` is ``true_rows(idx) -> (accel, gyro, R_ref_sensor)`` (``R`` may be None without
    ``orientation``): ``simulate_inertial`` (and ``simulate_orientation``) of the whole run,
    evaluated a block at a time."""
    t = np.asarray(t, float)
    n = len(t)
    acc = _Axis(rng, t, cfg.accel_noise_density, cfg.accel_bias_walk)
    gyr = _Axis(rng, t, cfg.gyro_noise_density, cfg.gyro_bias_walk)
    ori = _Orientation(rng, t, cfg) if orientation else None
    cache: dict[int, dict] = {}

    def block(b: int) -> dict:
        if b not in cache:
            idx = np.arange(b * BLOCK, min(n, (b + 1) * BLOCK))
            a_true, g_true, R_true = true_rows(idx)
            (a, b_a), (g, b_g) = acc.block(b, a_true), gyr.block(b, g_true)
            out = {"accel": a, "gyro": g, "accel_true": a_true, "gyro_true": g_true,
                   "accel_bias": b_a, "gyro_bias": b_g}
            if ori is not None:
                err = ori.block(b, len(idx))
                out.update(R=perturb_orientation(R_true, err), R_true=R_true, errors=err)
            cache.clear()
            cache[b] = out
        return cache[b]

    def field(name: str, tail: tuple[int, ...]) -> LazyArray:
        def fetch(idx: np.ndarray) -> np.ndarray:
            out = np.empty((len(idx), *tail))
            blocks = idx // BLOCK
            for b in np.unique(blocks).tolist():
                sel = blocks == b
                out[sel] = block(b)[name][idx[sel] - b * BLOCK]
            return out
        return LazyArray(n, tail, fetch)

    o = (OrientationSamples(t, field("R", (3, 3)), field("R_true", (3, 3)),
                            field("errors", (3,))) if ori is not None else None)
    return InertialSamples(t, field("accel", (3,)), field("gyro", (3,)),
                           field("accel_true", (3,)), field("gyro_true", (3,)),
                           field("accel_bias", (3,)), field("gyro_bias", (3,)), o)
