"""What the mimic stage records for scoring: preallocated arrays, one row per servo tick, plus
every estimate and measurement as it arrived. Positions in the robot base frame (m).

The per-tick arrays are :class:`~humimic.spill.SpillArray` (written and sliced like numpy
arrays, rows before the current block on disk) and arrivals are packed ``array('d')`` columns,
so a long run's record does not grow the process's memory.

Time conventions: row ``k`` is written at servo time ``t[k]``. The physical robot (``p_robot``,
``q_robot``, head and camera poses) is the state *at* ``t[k]``; the command, the IK solution
and the estimate used are for the *end* of the servo period, ``t[k] + dt``.
"""

from __future__ import annotations

from array import array
from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np

from humimic.spill import SpillArray


@dataclass
class Arrivals:
    """Values of one target as they arrived on a topic."""

    t: array = field(default_factory=lambda: array("d"))
    """Photon times (s)."""
    t_ready: array = field(default_factory=lambda: array("d"))
    p: array = field(default_factory=lambda: array("d"))
    """Positions, three values per arrival."""

    def add(self, t: float, t_ready: float, p: np.ndarray) -> None:
        self.t.append(t)
        self.t_ready.append(t_ready)
        self.p.extend(np.asarray(p, float).ravel()[:3])

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return (np.array(self.t), np.array(self.t_ready),
                np.array(self.p, float).reshape(-1, 3))


class MimicRecord:
    """Preallocated per-tick arrays (``n`` ticks, ``s`` driven sites, ``nq`` robot joints)."""

    def __init__(self, n: int, sites: list[str], nq: int, dt: float):
        s = len(sites)
        self.sites, self.dt, self.n = list(sites), dt, 0
        self.t = SpillArray(n)
        self.p_cmd = SpillArray(n, (s, 3), fill=np.nan)
        """Commanded site position (after mapping and clamping)."""
        self.p_cmd_raw = SpillArray(n, (s, 3), fill=np.nan)
        """The command before clamping into the reachable shell."""
        self.p_cmd_alt = SpillArray(n, (s, 3), fill=np.nan)
        """Command the *other* interpolation mode would have given (comparison only)."""
        self.p_ik = SpillArray(n, (s, 3))
        """Site position at the IK's solution."""
        self.p_robot = SpillArray(n, (s, 3))
        """Physical site position."""
        self.p_est = SpillArray(n, (s, 3), fill=np.nan)
        """Mapped position of the estimate in use (its photon time in ``t_est``)."""
        self.t_est = SpillArray(n, (s,), fill=np.nan)
        self.t_ready = SpillArray(n, (s,), fill=np.nan)
        """When the estimate in use became available (``t_est`` plus the pipeline's delay)."""
        self.scale = SpillArray(n, (s,), fill=np.nan)
        """Mapping scale in use (``mimic.fit`` may shrink it)."""
        self.clamped = SpillArray(n, (s,), bool, False)
        self.lost = SpillArray(n, (s,), bool, False)
        self.active = SpillArray(n, (s,), bool, False)
        self.q_ik = SpillArray(n, (nq,))
        self.qdot_ik = SpillArray(n, (nq,))
        self.ctrl = SpillArray(n, (nq,))
        self.q_robot = SpillArray(n, (nq,))
        self.p_head = SpillArray(n, (3,))
        self.R_head = SpillArray(n, (9,))
        self.cam_pos = SpillArray(n, (2, 3))
        self.cam_mat = SpillArray(n, (2, 9))
        self.ik_s = SpillArray(n)
        self.estimates: dict[str, Arrivals] = defaultdict(Arrivals)
        self.measurements: dict[str, Arrivals] = defaultdict(Arrivals)
        self.first_use: dict[str, array] = defaultdict(lambda: array("d"))
        """Per target: (photon time, t_ready, servo time of first use) of each estimate, three
        values per estimate."""

    def trimmed(self, name: str) -> np.ndarray:
        """The first ``n`` rows of an array attribute."""
        return getattr(self, name)[: self.n]
