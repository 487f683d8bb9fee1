"""Ground truth of a whole run, evaluated on demand: memory stays flat in the run's duration.

:class:`GroundTruth` holds every sample (~1.9 kB per physics tick: 1 GB for ten minutes at
840 Hz). :class:`LazyGroundTruth` has the same accessors, but each returns a
:class:`LazyArray`, an ``(N, ...)`` array-like that evaluates the motion only at the ticks it is
indexed with. Requests that cover a chunk of :data:`CHUNK` ticks densely (the simulation loop
walking forward) compute the whole chunk once and keep it in a small LRU cache of
:data:`CACHED_CHUNKS` chunks; sparse requests (camera frames across the run) evaluate just the
ticks asked for. Every value comes from :class:`GroundTruthSampler`, so the maths is
:class:`GroundTruth`'s: an accessor of the lazy object is that accessor of an eager
``GroundTruth`` restricted to the requested ticks.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable

import numpy as np
from numpy.lib.mixins import NDArrayOperatorsMixin

from humimic.motion.ground_truth import GroundTruth, GroundTruthSampler
from humimic.motion.trajectory import JointTrajectory, WindowedTrajectory

#: Ticks per cached chunk (~4 MB of ground truth each).
CHUNK = 2048
#: Chunks kept (the loop's current one, and recent ones that late frames still ask about).
CACHED_CHUNKS = 4
#: A chunk is computed whole (and cached) when a request touches at least this many of its ticks.
DENSE = CHUNK // 8


class LazyArray(NDArrayOperatorsMixin):
    """An ``(n, *tail)`` array evaluated on demand: ``fetch(idx)`` gives rows ``idx`` (int array).

    Indexing with an int, a slice or an integer/boolean array evaluates just those rows;
    ``[:, ...]`` gives another lazy array; numpy functions and operators see the whole array
    (``np.asarray``), which evaluates every row.
    """

    def __init__(self, n: int, tail: tuple[int, ...], fetch: Callable[[np.ndarray], np.ndarray]):
        self._n, self._tail, self._fetch = n, tuple(tail), fetch

    @property
    def shape(self) -> tuple[int, ...]:
        return (self._n, *self._tail)

    @property
    def ndim(self) -> int:
        return 1 + len(self._tail)

    dtype = np.dtype(float)

    def __len__(self) -> int:
        return self._n

    def rows(self, idx: np.ndarray) -> np.ndarray:
        """Rows at integer indices ``idx`` (any shape; negative from the end)."""
        idx = np.asarray(idx, dtype=np.int64)
        flat = np.where(idx.ravel() < 0, idx.ravel() + self._n, idx.ravel())
        if np.any((flat < 0) | (flat >= self._n)):
            raise IndexError(f"index out of range for a lazy array of length {self._n}")
        out = np.empty((len(flat), *self._tail))
        for s in range(0, len(flat), CHUNK // 2):  # bounded temporaries for whole-run requests
            out[s:s + CHUNK // 2] = self._fetch(flat[s:s + CHUNK // 2])
        return out.reshape(*idx.shape, *self._tail)

    def __getitem__(self, key):
        first, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        if isinstance(first, slice) and first == slice(None) and rest:
            probe = np.empty((0, *self._tail))[(slice(None), *rest)]
            return LazyArray(self._n, probe.shape[1:],
                             lambda idx: self._fetch(idx)[(slice(None), *rest)])
        if isinstance(first, (int, np.integer)):  # the simulation loop's path: one tick
            i = int(first) + (self._n if first < 0 else 0)
            if not 0 <= i < self._n:
                raise IndexError(f"index {first} out of range for a lazy array of length "
                                 f"{self._n}")
            out = self._fetch(np.array([i]))[0]
            return out[rest] if rest else out
        if isinstance(first, slice):
            out = self.rows(np.arange(self._n)[first])
        else:
            a = np.asarray(first)
            out = self.rows(np.flatnonzero(a) if a.dtype == bool else a)
        return out[(slice(None), *rest)] if rest else out

    def __array__(self, dtype=None, copy=None):
        out = self.rows(np.arange(self._n))
        return out if dtype is None else out.astype(dtype)

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        inputs = tuple(np.asarray(x) if isinstance(x, LazyArray) else x for x in inputs)
        return getattr(ufunc, method)(*inputs, **kwargs)

    def __repr__(self) -> str:
        return f"LazyArray(shape={self.shape})"


class LazyGroundTruth:
    """:class:`GroundTruth` at every physics tick ``k / rate`` (``k < n``), evaluated on demand.

    ``t``, ``targets`` and the constant poses are plain attributes; every per-tick field and
    accessor (``qpos``, ``pos``, ``p_base(name)``, ``pose(name, frame)``, ``sensors[name]``...)
    is a :class:`LazyArray`.
    """

    def __init__(self, sampler: GroundTruthSampler, n: int, rate: float):
        self._sampler, self.rate = sampler, float(rate)
        self.t = np.arange(n) / self.rate
        self.targets = sampler.targets
        scene = sampler.scene
        self.T_world_base = scene.T_world_base.copy()
        self.T_world_W = scene.T_world_W.copy()
        self.gravity = scene.model.opt.gravity.copy()
        self._cache: OrderedDict[int, GroundTruth] = OrderedDict()
        self.sensors = {name: self._field("sensors", name) for name in sampler.sensor_cols}

    @classmethod
    def for_run(cls, scene, motion, n: int, rate: float) -> LazyGroundTruth:
        """Ground truth of ``motion`` (a :class:`HumanMotion` or fitted trajectory) at ``n``
        physics ticks of ``rate`` Hz."""
        traj = (motion if isinstance(motion, JointTrajectory)
                else WindowedTrajectory(motion, max(n - 1, 1) / rate))
        return cls(GroundTruthSampler(scene, traj), n, rate)

    # ---- evaluation ------------------------------------------------------------------------
    def _chunk(self, c: int) -> GroundTruth:
        gt = self._cache.get(c)
        if gt is None:
            gt = self._sampler.sample(self.t[c * CHUNK:(c + 1) * CHUNK])
            self._cache[c] = gt
            if len(self._cache) > CACHED_CHUNKS:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(c)
        return gt

    def at(self, idx: np.ndarray) -> GroundTruth:
        """An eager :class:`GroundTruth` of the ticks ``idx`` (1-D int array), in that order."""
        parts, order = self._parts(idx)
        if len(parts) == 1:
            return parts[0]
        return _take(_concat(parts), np.argsort(np.concatenate(order), kind="stable"))

    def _parts(self, idx: np.ndarray) -> tuple[list[GroundTruth], list[np.ndarray]]:
        """``idx`` split by chunk: each chunk's ticks as a :class:`GroundTruth` (from the cache,
        a newly cached chunk, or evaluated alone) and their positions in ``idx``."""
        idx = np.asarray(idx, dtype=np.int64)
        chunk = idx // CHUNK
        ids, counts = np.unique(chunk, return_counts=True)
        parts, order = [], []
        for c, count in zip(ids.tolist(), counts.tolist(), strict=True):
            where = np.flatnonzero(chunk == c)
            if c in self._cache or count >= DENSE:
                parts.append(_take(self._chunk(c), idx[where] - c * CHUNK))
            else:
                parts.append(self._sampler.sample(self.t[idx[where]]))
            order.append(where)
        return parts, order

    def _values(self, idx: np.ndarray, get: Callable[[GroundTruth], np.ndarray]) -> np.ndarray:
        """``get`` of the ground truth at ``idx``, chunk by chunk (only ``get``'s values are
        gathered, not every field)."""
        parts, order = self._parts(idx)
        values = [get(p) for p in parts]
        if len(values) == 1:
            return values[0]
        out = np.empty((len(idx), *values[0].shape[1:]))
        for where, v in zip(order, values, strict=True):
            out[where] = v
        return out

    def _lazy(self, method: str, *args) -> LazyArray:
        return LazyArray(len(self.t), _ACCESSORS[method],
                         lambda idx: self._values(idx, lambda gt: getattr(gt, method)(*args)))

    def _field(self, name: str, key: str | None = None) -> LazyArray:
        def get(gt: GroundTruth) -> np.ndarray:
            value = getattr(gt, name)
            return value[key] if key is not None else value

        def fetch(idx: np.ndarray) -> np.ndarray:
            if len(idx) == 1:  # one tick (the simulation loop walks on): from its chunk
                c0 = int(idx[0]) // CHUNK
                return get(self._chunk(c0))[idx - c0 * CHUNK]
            c = idx // CHUNK
            c0 = int(c[0]) if len(c) else 0
            if len(c) and np.all(c == c0) and (c0 in self._cache or len(c) >= DENSE):
                return get(self._chunk(c0))[idx - c0 * CHUNK]  # the loop's path: one field
            return self._values(idx, get)

        s = self._sampler
        tail = {"qpos": (s.trajectory.nq,), "qvel": (s.trajectory.nv,),
                "R_imu": (len(s.oriented), 3, 3), "sensors": (_width(s.sensor_cols.get(key)),)
                }.get(name, (len(s.sites), 3))
        return LazyArray(len(self.t), tail, fetch)

    # ---- GroundTruth's interface -------------------------------------------------------------
    index_of = GroundTruth.index_of
    T_world_frame = GroundTruth.T_world_frame
    _k = GroundTruth._k

    def __getattr__(self, name: str):
        if name in _FIELDS:
            return self._field(name)
        if name in _ACCESSORS:
            return lambda *args: self._lazy(name, *args)
        raise AttributeError(name)

    def inertial(self, which: str) -> tuple[LazyArray, LazyArray]:
        prefix = {"head_imu": "head", "wiimote": "wiimote"}[which]
        return self.sensors[f"{prefix}_acc"], self.sensors[f"{prefix}_gyro"]

    def sensor(self, name: str) -> LazyArray:
        return self.sensors[name]


_FIELDS = ("qpos", "qvel", "pos", "vel", "acc", "angvel", "R_imu")
#: Accessors of :class:`GroundTruth` and the shape of one tick's value.
_ACCESSORS = {**dict.fromkeys(("p_world", "v_world", "a_world", "p_base", "v_base", "a_base",
                               "position", "velocity", "acceleration", "angular_velocity",
                               "specific_force"), (3,)),
              **dict.fromkeys(("R_world", "R_base", "rotation"), (3, 3)), "pose": (4, 4)}


def _width(cols: slice | None) -> int:
    return 0 if cols is None else cols.stop - cols.start


def _take(gt: GroundTruth, rows: np.ndarray) -> GroundTruth:
    """``gt`` restricted to ``rows`` (in that order)."""
    per_tick = {f: getattr(gt, f)[rows] for f in ("t", *_FIELDS)}
    return GroundTruth(**per_tick, targets=gt.targets,
                       sensors={k: v[rows] for k, v in gt.sensors.items()},
                       T_world_base=gt.T_world_base, T_world_W=gt.T_world_W, gravity=gt.gravity)


def _concat(parts: list[GroundTruth]) -> GroundTruth:
    first = parts[0]
    per_tick = {f: np.concatenate([getattr(p, f) for p in parts]) for f in ("t", *_FIELDS)}
    sensors = {k: np.concatenate([p.sensors[k] for p in parts]) for k in first.sensors}
    return GroundTruth(**per_tick, targets=first.targets, sensors=sensors,
                       T_world_base=first.T_world_base, T_world_W=first.T_world_W,
                       gravity=first.gravity)
