"""How well a frame's image cues observe a wrist's depth: the likelihood's profile along the
camera ray (a diagnostic of the monocular kernel particle filter, issue 14).

One camera sees a wrist up to its range. :func:`depth_profile` takes a pose ``q`` (e.g. the
true one) and a log-likelihood (e.g. the tracker's eqs. 9-10 on a frame's cues) and evaluates

* the pose with the arm's wrist moved by ``delta`` along its camera ray and the arm re-solved
  (:func:`~humimic.perception.trackers.kpf.depth.wrist_depth_move`: the wrist's image stays,
  its range changes by ``delta``), for each offset of a grid;
* the arm's kinematic mirror poses (:func:`~humimic.perception.trackers.kpf.flips.arm_flips`:
  the same elbow and wrist images, the elbow and / or the wrist on the other intersection of
  its ray with its bone's sphere).

:func:`within` reads the depth interval around ``q`` over which the log-likelihood stays
within some nats of ``q``'s (how far in depth the cues cannot tell the poses apart), and
:func:`ml_choice` what a maximum-likelihood estimator restricted to these poses would pick.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.depth import SIDES, wrist_depth_move
from humimic.perception.trackers.kpf.flips import FLIPS, arm_flips

#: A moved wrist this far (m) from its target on the ray means the move was not possible
#: (out of reach or out of the joint limits: :func:`wrist_depth_move` keeps the pose).
REACHED_M = 1e-6


@dataclass(frozen=True)
class DepthProfile:
    """One pose's log-likelihood along its wrist's depth and at its mirror poses."""

    delta: np.ndarray
    """(K,) range offsets of the wrist along its camera ray (m, + away from the camera)."""
    log_lik: np.ndarray
    """(K,) log-likelihood of the re-solved pose; NaN where the wrist cannot get there."""
    truth: float
    """The log-likelihood of ``q`` itself (``delta = 0``)."""
    flip_log_lik: dict[str, float]
    """:data:`~humimic.perception.trackers.kpf.flips.FLIPS` -> the mirror pose's
    log-likelihood (NaN where it does not exist or is out of the joint limits)."""
    flip_wrist_m: dict[str, float]
    """The same flips -> the distance (m) of their wrist from ``q``'s."""
    wrist: np.ndarray
    """(K, 3) the re-solved poses' wrists (reference frame; NaN where unreachable)."""
    flip_wrist: dict[str, np.ndarray]
    """The flips -> their wrist (3,) (NaN where there is no such mirror)."""

    @property
    def flip_margin(self) -> float:
        """``truth`` minus the best mirror's log-likelihood (nats; NaN without a mirror):
        positive where the cues rank ``q`` above all its mirrors."""
        v = np.array(list(self.flip_log_lik.values()), float)
        return float(self.truth - np.nanmax(v)) if np.any(np.isfinite(v)) else float("nan")


def depth_profile(body: bm.BodyModel, log_lik: Callable[[np.ndarray], np.ndarray],
                  q: np.ndarray, T_cam_ref: np.ndarray, delta: np.ndarray, side: str = "R"
                  ) -> DepthProfile:
    """The profile of ``log_lik`` (states ``(N, 14)`` -> ``(N,)``, called once) around pose
    ``q (14,)`` along the wrist of arm ``side``'s camera ray (``T_cam_ref``: reference-frame
    points -> camera) at range offsets ``delta (K,)`` (m), and at the arm's mirror poses."""
    q = np.asarray(q, float)
    delta = np.asarray(delta, float)
    prefix, _ = SIDES[side]
    wrist = f"{prefix}_wrist"
    c_ref = np.linalg.inv(np.asarray(T_cam_ref, float))[:3, 3]
    W = body.forward(q[None]).joint(wrist)[0]
    u = (W - c_ref) / np.linalg.norm(W - c_ref)
    moved = wrist_depth_move(body, np.repeat(q[None], len(delta), axis=0), side, delta,
                             T_cam_ref)
    target = W + delta[:, None] * u
    w_moved = body.forward(moved).joint(wrist)
    reached = np.linalg.norm(w_moved - target, axis=1) <= REACHED_M
    flips = arm_flips(body, q[None], side, c_ref)
    names = list(FLIPS)
    fq = np.concatenate([flips[n] for n in names])
    fok = np.all(np.isfinite(fq), axis=1)
    fok[fok] = body.free_limits.inside(fq[fok])
    ll = np.asarray(log_lik(np.concatenate([q[None], moved[reached], fq[fok]])), float)
    prof = np.full(len(delta), np.nan)
    prof[reached] = ll[1:1 + reached.sum()]
    fll = np.full(len(names), np.nan)
    fll[fok] = ll[1 + reached.sum():]
    fwp = np.full((len(names), 3), np.nan)
    if fok.any():
        fwp[fok] = body.forward(fq[fok]).joint(wrist)
    fw = np.linalg.norm(fwp - W, axis=1)
    return DepthProfile(delta, prof, float(ll[0]), dict(zip(names, fll.tolist(), strict=True)),
                        dict(zip(names, fw.tolist(), strict=True)),
                        np.where(reached[:, None], w_moved, np.nan),
                        dict(zip(names, fwp, strict=True)))


def within(delta: np.ndarray, log_lik: np.ndarray, ref: float, nats: float
           ) -> tuple[float, float, bool]:
    """The interval ``(lo, hi)`` (m) of offsets around ``delta = 0`` over which ``log_lik``
    stays at or above ``ref - nats`` (linearly interpolated at the crossings), and whether it
    is censored by the grid (it reaches the grid's end on either side: the true interval is
    wider). An offset the arm cannot reach (NaN) ends the interval at the last reachable one
    (the arm's length or joint limits bound the depth there, not the cues). ``delta``
    ascending, containing 0."""
    delta, ll = np.asarray(delta, float), np.asarray(log_lik, float)
    i0 = int(np.argmin(np.abs(delta)))
    floor = ref - nats
    ends, censored = [], False
    for step in (-1, 1):
        i = i0
        while 0 <= i + step < len(delta) and ll[i + step] >= floor:
            i += step
        j = i + step
        if not 0 <= j < len(delta) or not np.isfinite(ll[j]):
            ends.append(delta[i])
            censored |= not 0 <= j < len(delta)
            continue
        a = (ll[i] - floor) / (ll[i] - ll[j])          # ll[i] >= floor > ll[j]
        ends.append(delta[i] + a * (delta[j] - delta[i]))
    return float(ends[0]), float(ends[1]), censored


def ml_wrist(p: DepthProfile) -> np.ndarray:
    """The wrist (3,) of the pose :func:`ml_choice` picks (reference frame)."""
    kind, _ = ml_choice(p)
    if kind != "ray":
        return p.flip_wrist[kind]
    k = int(np.nanargmax(p.log_lik)) if np.any(np.isfinite(p.log_lik)) else None
    return p.wrist[int(np.argmin(np.abs(p.delta)))] if k is None else p.wrist[k]


def ml_choice(p: DepthProfile) -> tuple[str, float]:
    """What maximises the log-likelihood among the profile's poses and the mirrors: ``("ray",
    offset)`` (the offset in m, signed) or ``(flip, wrist distance)`` (m) -- the wrist error
    of a maximum-likelihood estimator over these poses when ``q`` is the truth."""
    k = int(np.nanargmax(p.log_lik)) if np.any(np.isfinite(p.log_lik)) else None
    best, out = (p.truth, ("ray", 0.0)) if k is None else (p.log_lik[k],
                                                           ("ray", float(p.delta[k])))
    for name, ll in p.flip_log_lik.items():
        if np.isfinite(ll) and ll > best:
            best, out = ll, (name, p.flip_wrist_m[name])
    return out
