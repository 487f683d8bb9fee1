"""The scenario's ``filter`` section: the random-jerk Kalman filter of Ude & Atkeson.

Example::

    filter:
      kind: random_jerk
      b: 27.5          # m s^-2.5 (the paper's b = 27500 with millimetres)
      max_gap: 0.2     # s of prediction only before a lost target's filter is reset
      coast_tau_v: 0.15      # s: velocity decay while coasting (null: Ude's extrapolation)
      coast_tau_a: 0.05      # s: acceleration decay while coasting
      gate_probability: 0.9999   # chi-square innovation gate, 3 dof (null: no gate)
      gate_reinit_after: 3       # consecutive gated measurements that re-initialise
      noise_match: 8.0           # R scaled when the measurements scatter > 8x its variance
      noise_match_window: 12     # consecutive measurements that estimate the scatter

Units: m, s.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from humimic.estimation.random_jerk import B_PAPER_SI, INIT_ACC_VAR, INIT_VEL_VAR
from humimic.scenario.base import Section, reject_idle_options

NEEDS: dict[str, tuple[str, ...]] = {"coast_tau_a": ("coast_tau_v",),
                                     "gate_reinit_after": ("gate_probability",),
                                     "noise_match_window": ("noise_match",)}
"""Options that act only with another on: option -> the options that switch it on."""


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
    coast_tau_v: float | None = Field(0.15, gt=0.0, le=60.0)
    """Time constant (s) with which the velocity decays in frames predicted without a
    measurement (:mod:`humimic.estimation.coasting`: a mean-reverting hand, about a quarter of
    a 0.5-1 s gesture stroke); null: Ude's constant-acceleration extrapolation (1-2 m off
    after 0.2 s of coasting on bad measurements, ude_cmu_turn)."""
    coast_tau_a: float = Field(0.05, gt=0.0, le=60.0)
    """Time constant (s) of the acceleration's decay while coasting (Singer's manoeuvre time
    constant); acts only with ``coast_tau_v``."""
    gate_probability: float | None = Field(0.9999, gt=0.5, lt=1.0)
    """Chi-square innovation gate (Bar-Shalom et al. 2001, sec. 5.4): a measurement whose
    normalised innovation squared exceeds the chi2(3) quantile of this probability (0.9999:
    21.1) is rejected and the frame coasts (``filter.gated_measurements``); null: no gate."""
    gate_reinit_after: int = Field(3, ge=1, le=1000)
    """Consecutive gated measurements after which the filter is re-initialised from the
    measurement (as after ``max_gap``; ``filter.gate_reinits``): the target really moved."""
    noise_match: float | None = Field(8.0, gt=1.0, le=1.0e4)
    """When a target's last ``noise_match_window`` measurements scatter more than this many
    times the variance R says (the median of their second differences' chi-square ratios,
    :mod:`humimic.estimation.noise_match`), fuse them with R times that ratio
    (``filter.noise_scaled_frames``); null: R as perception reports it. 8: the ratio of the
    shipped scenarios' measurements stays below 4.4 (their median 0.2-2.6); with R 7x too small
    in standard deviation it is 15-18, and the gate, seeing every innovation outside,
    re-initialised the filter every 5 frames."""
    noise_match_window: int = Field(12, ge=5, le=600)
    """Consecutive measurements (frames) over which ``noise_match`` estimates the scatter."""
    latency: float = Field(0.0, ge=0.0, le=0.5)
    """Declared processing latency (s) added to each estimate's ready time."""

    @model_validator(mode="after")
    def _idle(self) -> FilterConfig:
        reject_idle_options(self, NEEDS)
        return self
