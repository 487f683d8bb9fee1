"""Forward kinematics for tests: site positions over a sequence of configurations (MuJoCo's own
``mj_kinematics``, the independent reference for the motion code)."""

from __future__ import annotations

import mujoco
import numpy as np


def site_positions(m: mujoco.MjModel, qpos: np.ndarray, names: list[str],
                   d: mujoco.MjData | None = None) -> dict[str, np.ndarray]:
    """``{site: (N, 3) world positions}`` for each configuration in ``qpos`` (N, nq)."""
    d = d if d is not None else mujoco.MjData(m)
    out = {n: [] for n in names}
    for q in qpos:
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        for n in names:
            out[n].append(d.site(n).xpos.copy())
    return {n: np.array(v) for n, v in out.items()}
