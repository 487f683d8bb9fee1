"""The IK's QP objective and collision rows, assembled without mink's per-call Python layers.

:func:`humimic.control.ik.qp_objective` builds ``(H, c)`` by asking each mink task for its
weighted residual: per task and servo tick that means fresh arrays, SE(3) objects, frame-id
look-ups and attribute dispatch - most of the IK's cost at 420 Hz, for a problem of 30
joints. :class:`TaskStack` does the same arithmetic with the same functions (mink's compiled
Lie-group helpers, ``mj_jacSite``, the same BLAS products on arrays of the same shapes) into
buffers allocated once, so its ``(H, c)`` equals ``qp_objective``'s bit for bit (tested), and
:class:`CollisionRows` returns only the rows of the collision limit that constrain the step,
in mink's row order.
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np

try:  # mink's compiled SE(3) helpers (what its FrameTask uses when they are there)
    from mink.lie import _lie_ops_c as _native
except ImportError:  # pragma: no cover - mink without its extension
    _native = None

_JAC = {"site": mujoco.mj_jacSite, "body": mujoco.mj_jacBody, "geom": mujoco.mj_jacGeom}
_POS = {"site": "site_xpos", "body": "xpos", "geom": "geom_xpos"}
_MAT = {"site": "site_xmat", "body": "xmat", "geom": "geom_xmat"}


class TaskStack:
    """``(H, c)`` of ``qp_objective(configuration, tasks, damping)`` for mink ``FrameTask``s and
    ``PostureTask``s (others are asked through mink). Task costs, gains and damping are read
    at construction; targets at every call (they move)."""

    def __init__(self, configuration: mink.Configuration, tasks, damping: float):
        model = configuration.model
        self.model, self.nv, self.damping = model, model.nv, damping
        self._plan = []
        row = 0
        for task in tasks:
            k = self.nv if isinstance(task, mink.PostureTask) else task.k
            sl = slice(row, row + k)
            row += k
            cost = np.asarray(task.cost, float)
            if isinstance(task, mink.FrameTask) and _native is not None:
                fid = configuration._resolve_frame_id(task.frame_name, task.frame_type)
                self._plan.append(("frame", task, sl, cost, fid,
                                   _JAC[task.frame_type], _POS[task.frame_type],
                                   _MAT[task.frame_type]))
            elif isinstance(task, mink.PostureTask):
                jac = np.eye(self.nv)
                if task._v_ids is not None:
                    jac[:, task._v_ids] = 0.0
                self._plan.append(("posture", task, sl, cost, cost[:, None] * jac))
            else:
                self._plan.append(("other", task, sl))
        self.W = np.empty((row, self.nv))
        self.e = np.empty(row)
        self._jac = np.empty((6, self.nv))
        self._qvel = np.empty(self.nv)
        self._data, self._arrays = None, {}

    def __call__(self, configuration: mink.Configuration) -> tuple[np.ndarray, np.ndarray]:
        model, data = self.model, configuration.data
        W, e, mu = self.W, self.e, 0.0
        if data is not self._data:  # MjData's arrays, fetched once (each access makes a view)
            self._data = data
            self._arrays = {a: getattr(data, a) for a in {*_POS.values(), *_MAT.values()}}
        arrays = self._arrays
        for step in self._plan:
            kind, task, sl = step[:3]
            if kind == "frame":  # mink FrameTask._error_and_jacobian + _weighted_residual
                cost, fid, jac_fn, pos, mat = step[3:]
                xmat = arrays[mat][fid]
                frame = _native.xmat_xpos_to_wxyz_xyz(xmat, arrays[pos][fid])
                jac = self._jac
                jac_fn(model, data, jac[:3], jac[3:], fid)
                jac = _native.se3_rotation_adjoint_from_xmat(xmat) @ jac
                target = task.transform_target_to_world.wxyz_xyz
                error = _native.se3_rminus(target, frame)
                jac = -_native.se3_jlog(_native.se3_inverse_multiply(target, frame)) @ jac
                we = cost * (-task.gain * error)
                np.multiply(cost[:, None], jac, out=W[sl])
            elif kind == "posture":  # mink PostureTask.compute_error / compute_jacobian
                cost, wjac = step[3:]
                qvel = self._qvel
                mujoco.mj_differentiatePos(model, qvel, 1.0, task.target_q, configuration.q)
                if task._v_ids is not None:
                    qvel[task._v_ids] = 0.0
                we = cost * (-task.gain * qvel)
                W[sl] = wjac
            else:
                wj, we, m = task.compute_qp_residual(configuration)
                W[sl] = wj
                e[sl] = we
                mu += m
                continue
            e[sl] = we
            mu += task.lm_damping * float(we @ we)
        H = W.T @ W
        H.flat[:: H.shape[0] + 1] += self.damping + mu
        return H, -(e @ W)


class CollisionRows:
    """The rows ``(G, h)`` of ``limit.compute_qp_inequalities`` (a
    :class:`~humimic.control.ik.DisplacementCollisionLimit`) whose bound is finite, in the same
    order: only geom pairs that pass the broadphase (bounding spheres, as mink's) and lie
    within the detection distance are measured."""

    def __init__(self, limit):
        self.limit = limit
        model = limit.model
        pairs = np.array(limit.geom_id_pairs, dtype=int).reshape(-1, 2)
        rb = model.geom_rbound
        self._spheres = bool(limit.broadphase and len(pairs) >= limit.broadphase_min_pairs
                             and np.all((rb[pairs[:, 0]] > 0) & (rb[pairs[:, 1]] > 0)))
        self._g = np.concatenate([pairs[:, 0], pairs[:, 1]])
        bound = rb[pairs[:, 0]] + rb[pairs[:, 1]] + limit.collision_detection_distance
        self._bound2 = bound * bound
        self._n = len(pairs)
        self._nv = model.nv
        self._empty = (np.zeros((0, model.nv)), np.zeros(0))

    def _candidates(self, data) -> list[int]:
        """Pair indices (ascending) that may be within the detection distance."""
        lim = self.limit
        if self._spheres:  # mink's sphere-sphere broadphase over every pair, in one go
            # (a conservative filter: a pair it lets through in excess measures the detection
            # distance exactly and is skipped, so rounding here never changes the rows)
            x = data.geom_xpos[self._g]
            d = x[:self._n] - x[self._n:]
            np.multiply(d, d, out=d)
            return np.flatnonzero(d.sum(1) <= self._bound2).tolist()
        if lim.broadphase and lim.max_num_contacts >= lim.broadphase_min_pairs:
            return np.sort(lim._broadphase_survivors(data)).tolist()
        return list(range(lim.max_num_contacts))

    def __call__(self, configuration: mink.Configuration) -> tuple[np.ndarray, np.ndarray]:
        lim = self.limit
        model, data = lim.model, configuration.data
        distmax = lim.collision_detection_distance
        d_min, gain, recovery = lim.minimum_distance_from_collisions, lim.gain, lim.max_recovery
        fromto, normal, jac1, jac2 = lim._fromto, lim._normal, lim._jac1, lim._jac2
        pairs, body = lim.geom_id_pairs, model.geom_bodyid
        rows, h = [], []
        for idx in self._candidates(data):
            g1, g2 = pairs[idx]
            dist = mujoco.mj_geomDistance(model, data, g1, g2, distmax, fromto)
            if abs(dist - distmax) < 1e-12:
                continue
            # mink's compute_contact_normal_jacobian, inline
            normal[:] = fromto[3:] - fromto[:3]
            mujoco.mju_normalize3(normal)
            mujoco.mj_jac(model, data, jac2, None, fromto[3:], body[g2])
            mujoco.mj_jac(model, data, jac1, None, fromto[:3], body[g1])
            jac2 -= jac1
            row = normal @ jac2
            rows.append(-row if dist >= 0 else row)
            h.append(max(gain * (dist - d_min), -recovery))
        if not rows:
            return self._empty
        return np.array(rows), np.array(h)
