"""What the mimic stage records for scoring: preallocated arrays, one row per servo tick, plus
every estimate and measurement as it arrived. Positions in the robot base frame (m).

Time conventions: row ``k`` is written at servo time ``t[k]``. The physical robot (``p_robot``,
``q_robot``, head and camera poses) is the state *at* ``t[k]``; the command, the IK solution
and the estimate used are for the *end* of the servo period, ``t[k] + dt``.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Arrivals:
    """Values of one target as they arrived on a topic."""

    t: list[float] = field(default_factory=list)
    """Photon times (s)."""
    t_ready: list[float] = field(default_factory=list)
    p: list[np.ndarray] = field(default_factory=list)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p = np.array(self.p) if self.p else np.zeros((0, 3))
        return np.array(self.t), np.array(self.t_ready), p


class MimicRecord:
    """Preallocated per-tick arrays (``n`` ticks, ``s`` driven sites, ``nq`` robot joints)."""

    def __init__(self, n: int, sites: list[str], nq: int, dt: float):
        s = len(sites)
        self.sites, self.dt, self.n = list(sites), dt, 0
        self.t = np.zeros(n)
        self.p_cmd = np.full((n, s, 3), np.nan)
        """Commanded site position (after mapping and clamping)."""
        self.p_cmd_raw = np.full((n, s, 3), np.nan)
        """The command before clamping into the reachable shell."""
        self.p_cmd_alt = np.full((n, s, 3), np.nan)
        """Command the *other* interpolation mode would have given (comparison only)."""
        self.p_ik = np.zeros((n, s, 3))
        """Site position at the IK's solution."""
        self.p_robot = np.zeros((n, s, 3))
        """Physical site position."""
        self.p_est = np.full((n, s, 3), np.nan)
        """Mapped position of the estimate in use (its photon time in ``t_est``)."""
        self.t_est = np.full((n, s), np.nan)
        self.scale = np.full((n, s), np.nan)
        """Mapping scale in use (``mimic.fit`` may shrink it)."""
        self.clamped = np.zeros((n, s), bool)
        self.lost = np.zeros((n, s), bool)
        self.active = np.zeros((n, s), bool)
        self.q_ik = np.zeros((n, nq))
        self.qdot_ik = np.zeros((n, nq))
        self.ctrl = np.zeros((n, nq))
        self.q_robot = np.zeros((n, nq))
        self.p_head = np.zeros((n, 3))
        self.R_head = np.zeros((n, 9))
        self.cam_pos = np.zeros((n, 2, 3))
        self.cam_mat = np.zeros((n, 2, 9))
        self.ik_s = np.zeros(n)
        self.estimates: dict[str, Arrivals] = defaultdict(Arrivals)
        self.measurements: dict[str, Arrivals] = defaultdict(Arrivals)
        self.first_use: dict[str, list[tuple[float, float, float]]] = defaultdict(list)
        """Per target: (photon time, t_ready, servo time of first use) of each estimate."""

    def trimmed(self, name: str) -> np.ndarray:
        """The first ``n`` rows of an array attribute."""
        return getattr(self, name)[: self.n]
