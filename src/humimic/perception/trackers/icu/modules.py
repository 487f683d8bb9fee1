"""Fig. 15's module switch (Menezes sec. 7.1.2): which tracking module follows the tutor, chosen
from the human-robot distance and the face-recognition status.

``init`` -- the tutor is not (or no longer) tracked and recognised: the ICU tracker searches
(INIT and the face recognition, HumRec); ``icu`` -- the tutor tracked far away: the image-based
upper-body tracker ICU is the module; ``near`` -- the tutor tracked and closer than
``enter_m``: the 3-D module named by ``near.module`` (e.g. a ``tbp`` or ``gest`` tracker) takes
over until the tutor is farther than ``leave_m`` (hysteresis against the noise of the
distance). The distance is the pinhole range of the ICU estimate's head width,
``Z = f_x W / s`` (W the head's physical width); the tutor counts as tracked until the ICU
tracker has been off a recognised face for ``hold_s`` (the last distance kept). The ICU
tracker keeps running in every state
(the paper invokes it from 1 to 5 m, and its face recognition gates the switch); the near
module gets frames only in ``near`` (:class:`GatedStage`).
"""

from __future__ import annotations

import numpy as np

MODULES = ("init", "icu", "near")


def head_distance_m(fx_px: float, head_px: float, head_m: float) -> float:
    """Pinhole range of a head ``head_m`` wide seen ``head_px`` wide: ``f_x W / s``."""
    return float(fx_px * head_m / head_px) if head_px > 0 else float("inf")


def next_module(module: str, tracked: bool, distance_m: float, enter_m: float,
                leave_m: float) -> str:
    """Fig. 15's transition: ``tracked`` -- the ICU tracker follows a face recognised as the
    tutor (else back to ``init``); then ``near`` below ``enter_m``, back to ``icu`` above
    ``leave_m``."""
    if not tracked or not np.isfinite(distance_m):
        return "init"
    if module == "near":
        return "near" if distance_m <= leave_m else "icu"
    return "near" if distance_m < enter_m else "icu"


def module_scores(t: np.ndarray, modules: list[str], true_m: np.ndarray, visible: np.ndarray,
                  enter_m: float, leave_m: float) -> dict:
    """Frames per module; the switches ``(t, from, to)``; ``agreement``: over the frames where
    the tutor is visible and truly nearer than ``enter_m`` or farther than ``leave_m``, the
    fraction whose module is the right one (``near`` / ``icu``); ``switch_delay_s``: per true
    crossing of ``enter_m`` inwards or ``leave_m`` outwards, the time to the module's switch
    (None if it never came)."""
    t, true_m = np.asarray(t, float), np.asarray(true_m, float)
    m = np.asarray(modules)
    out: dict = {"frames": {k: int(np.sum(m == k)) for k in MODULES}}
    out["switches"] = [[round(float(t[k]), 4), str(m[k - 1]), str(m[k])]
                       for k in range(1, len(m)) if m[k] != m[k - 1]]
    near, far = visible & (true_m < enter_m), visible & (true_m > leave_m)
    judged = near | far
    right = (near & (m == "near")) | (far & (m == "icu"))
    out["agreement"] = float(right[judged].mean()) if judged.any() else None
    delays = []
    for k in range(1, len(t)):
        for want, crossed in (("near", true_m[k - 1] >= enter_m > true_m[k]),
                              ("icu", true_m[k - 1] <= leave_m < true_m[k])):
            if crossed:
                hit = np.flatnonzero(m[k:] == want)
                delays.append(round(float(t[k + hit[0]] - t[k]), 4) if len(hit) else None)
    out["switch_delay_s"] = delays
    return out


class _GatedBus:
    """A bus whose subscriptions deliver only while ``is_open()``."""

    def __init__(self, bus, is_open):
        self._bus, self._open = bus, is_open

    def subscribe(self, topic: str, handler) -> None:
        self._bus.subscribe(topic, lambda tp, msg: handler(tp, msg) if self._open() else None)

    def __getattr__(self, name):
        return getattr(self._bus, name)


class GatedStage:
    """Another stage that receives bus messages only while ``is_open()`` (the module chosen);
    everything else (metrics, logging, publishing) is the stage's own."""

    def __init__(self, inner, is_open):
        self.inner, self.is_open = inner, is_open

    def attach(self, bus, timer) -> None:
        self.inner.attach(_GatedBus(bus, self.is_open), timer)

    def __getattr__(self, name):
        return getattr(self.inner, name)
