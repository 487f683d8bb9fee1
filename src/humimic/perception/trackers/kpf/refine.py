"""A local refinement of the kpf's reported mode (our extension beyond Schmidt et al.).

Mean shift ends within a bandwidth of a likelihood peak, not on it; in the holds of Table 1
the tracker's estimate scores below the true pose under its own likelihood (a search failure)
and drifts along the camera ray. :func:`refine_arms` climbs the likelihood from the mode by a
deterministic pattern search (:func:`~humimic.maths.pattern_search.pattern_search`) on each
arm's four DOFs, polling along each joint axis (steps ``step`` x D) and along the arm's
depth direction (:func:`depth_direction`: the joint-space direction that moves the wrist along
its camera ray keeping its image, steps ``depth_step_m``), where a random walk in joint space
is slowest.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from humimic import bodymodel as bm
from humimic.maths.pattern_search import pattern_search
from humimic.perception.trackers.kpf.depth import SIDES, wrist_depth_move

#: The range change (m) of the finite difference giving the depth direction.
DEPTH_EPS_M = 0.002


def depth_direction(body: bm.BodyModel, q: np.ndarray, side: str, T_cam_ref: np.ndarray
                    ) -> np.ndarray | None:
    """``(4,)`` the change of arm ``side``'s DOFs per metre of its wrist moved away from the
    camera along its ray (a central difference of
    :func:`~humimic.perception.trackers.kpf.depth.wrist_depth_move`); None where the moved arm
    leaves its reach or limits."""
    _, j = SIDES[side]
    q2 = np.repeat(np.asarray(q, float)[None], 2, axis=0)
    moved = wrist_depth_move(body, q2, side, np.array([DEPTH_EPS_M, -DEPTH_EPS_M]), T_cam_ref)
    if np.any(np.all(moved == q2, axis=1)):
        return None
    return (moved[0, j:j + 4] - moved[1, j:j + 4]) / (2 * DEPTH_EPS_M)


def refine_arms(body: bm.BodyModel, q: np.ndarray, log_lik: Callable[[np.ndarray], np.ndarray],
                D: np.ndarray, T_cam_ref: np.ndarray, polls: int, step: float,
                depth_step_m: float, limits: bm.JointLimits, sides=tuple(SIDES)
                ) -> tuple[np.ndarray, int]:
    """The pose ``q (14,)`` with each arm of ``sides`` in turn moved uphill on ``log_lik``
    (``(M, 14) -> (M,)``) by ``polls`` pattern-search polls, ``(q, evaluations)``; never
    scores lower."""
    x = np.asarray(q, float).copy()
    n = 0
    for side in sides:
        _, j = SIDES[side]
        dof = slice(j, j + 4)
        dirs, steps = list(np.eye(4)), list(step * np.asarray(D[dof], float))
        u = depth_direction(body, x, side, T_cam_ref) if depth_step_m > 0 else None
        if u is not None:
            dirs.append(u)
            steps.append(depth_step_m)
        base = x.copy()

        def f(a, base=base, dof=dof):
            full = np.repeat(base[None], len(a), axis=0)
            full[:, dof] = a
            return log_lik(full)

        def project(a, base=base, dof=dof):
            full = np.repeat(base[None], len(a), axis=0)
            full[:, dof] = a
            return limits.clamp(full)[:, dof]

        res = pattern_search(f, x[dof], np.array(dirs), np.array(steps), polls,
                             project=project)
        x[dof] = res.x
        n += res.evaluations
    return x, n
