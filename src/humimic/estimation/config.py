"""The scenario's ``filter`` section: the random-jerk Kalman filter of Ude & Atkeson.

Example::

    filter:
      kind: random_jerk
      b: 27.5          # m s^-2.5 (the paper's b = 27500 with millimetres)
      max_gap: 0.2     # s of prediction only before a lost target's filter is reset

Units: m, s.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from humimic.estimation.random_jerk import B_PAPER_SI, INIT_ACC_VAR, INIT_VEL_VAR
from humimic.scenario.base import Section


class FilterConfig(Section):
    """One filter per perceived target; estimates published for every frame once initialised."""

    kind: Literal["random_jerk"] = "random_jerk"
    b: float = Field(B_PAPER_SI, gt=0.0, le=1.0e4)
    """Spectral amplitude of the random jerk (m s^-2.5, Ude eq. 12); the paper's 27500 mm
    s^-2.5 is 27.5. Smaller: smoother, larger: closer to the measurements."""
    init_vel_std: float = Field(INIT_VEL_VAR**0.5, gt=0.0)
    """Initial velocity standard deviation (m/s): 'very large' (the state starts at v = 0)."""
    init_acc_std: float = Field(INIT_ACC_VAR**0.5, gt=0.0)
    """Initial acceleration standard deviation (m/s^2), likewise."""
    max_gap: float = Field(0.2, gt=0.0, le=60.0)
    """A target unmeasured for longer than this (s) is dropped: its filter is reset and
    re-initialised by the next measurement (Ude's initialisation). Until then missed frames
    are predicted and published."""
    latency: float = Field(0.0, ge=0.0, le=0.5)
    """Declared processing latency (s) added to each estimate's ready time."""
