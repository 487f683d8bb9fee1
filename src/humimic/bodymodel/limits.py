"""Joint limits of the body model: a validated box in state space, and its scenario section.

:class:`JointLimits` is what the library uses (SI units: m, rad; raises ``ValueError`` naming
the DOF when a lower limit is not below its upper limit). :class:`JointLimitsConfig` is the
typed section a tracker's scenario config embeds (degrees and metres in the key names), so a
bad limit exits with code 2 naming the dotted key, like every scenario error.

Default limits (:data:`DEFAULT_LIMITS`) are a person's range of motion in DB's joint
convention (wider than DB's own, which are deliberately tight): shoulder flexion -60..180 deg,
abduction -30..180 deg, humeral rotation -100..100 deg (the avatar points sideways with its
upper arm turned out by 90 deg), elbow flexion 0..150 deg (the avatar's
elbow stops at 149 deg); torso turns +-180 deg, leans -30..60 deg forward and +-45 deg sideways;
torso position unbounded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import numpy as np
from pydantic import AfterValidator

from humimic.bodymodel.kinematics import DOF_NAMES, SIDES
from humimic.scenario.base import Section

_ARM_DEG = {"SFE": (-60.0, 180.0), "SAA": (-30.0, 180.0), "HR": (-100.0, 100.0),
            "EB": (0.0, 150.0)}
_TORSO = {"torso_x": (-math.inf, math.inf), "torso_y": (-math.inf, math.inf),
          "torso_z": (-math.inf, math.inf), "torso_yaw": (-math.pi, math.pi),
          "torso_pitch": (math.radians(-30.0), math.radians(60.0)),
          "torso_roll": (math.radians(-45.0), math.radians(45.0))}
#: DOF name -> (lower, upper) in SI units (m, rad).
DEFAULT_LIMITS: dict[str, tuple[float, float]] = {
    **_TORSO,
    **{f"{s}_{j}": (math.radians(lo), math.radians(hi))
       for s in SIDES for j, (lo, hi) in _ARM_DEG.items()},
}


@dataclass(frozen=True)
class JointLimits:
    """Lower and upper limits ``(D,)`` for the DOFs ``names`` (m for translations, rad)."""

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray

    def __post_init__(self) -> None:
        lo = np.asarray(self.lower, float).copy()
        hi = np.asarray(self.upper, float).copy()
        if lo.shape != (len(self.names),) or hi.shape != (len(self.names),):
            raise ValueError(f"joint limits: expected {len(self.names)} lower and upper values "
                             f"for {self.names}, got shapes {lo.shape} and {hi.shape}")
        for name, a, b in zip(self.names, lo, hi, strict=True):
            if np.isnan(a) or np.isnan(b) or not a < b:
                raise ValueError(f"joint limits: {name}: lower limit {a:g} must be below the "
                                 f"upper limit {b:g}")
        lo.setflags(write=False)
        hi.setflags(write=False)
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @classmethod
    def default(cls, names: tuple[str, ...] = DOF_NAMES, **overrides) -> JointLimits:
        """:data:`DEFAULT_LIMITS` for ``names``; ``overrides`` maps a DOF to ``(lo, hi)`` (SI)."""
        unknown = set(overrides) - set(DEFAULT_LIMITS)
        if unknown:
            raise ValueError(f"joint limits: unknown DOF {sorted(unknown)}; DOFs are "
                             f"{', '.join(DEFAULT_LIMITS)}")
        table = {**DEFAULT_LIMITS, **overrides}
        return cls(tuple(names), np.array([table[n][0] for n in names]),
                   np.array([table[n][1] for n in names]))

    def subset(self, names: tuple[str, ...]) -> JointLimits:
        idx = [self.names.index(n) for n in names]
        return JointLimits(tuple(names), self.lower[idx], self.upper[idx])

    def clamp(self, q: np.ndarray) -> np.ndarray:
        """``q (..., D)`` enforced to the limits (Menezes sec. 6.3.1: clamped, not rejected)."""
        return np.clip(q, self.lower, self.upper)

    def inside(self, q: np.ndarray) -> np.ndarray:
        """``(...)`` bool: every DOF of ``q (..., D)`` within its limits."""
        q = np.asarray(q, float)
        return np.all((q >= self.lower) & (q <= self.upper), axis=-1)


def _ordered(r: tuple[float, float]) -> tuple[float, float]:
    if not r[0] < r[1]:
        raise ValueError(f"lower limit {r[0]:g} must be below the upper limit {r[1]:g}")
    return r


Range = Annotated[tuple[float, float], AfterValidator(_ordered)]


class JointLimitsConfig(Section):
    """Joint limits for a tracker's scenario config: ``[lower, upper]`` per DOF, in the unit
    the key names; a DOF left out keeps the library's default (:data:`DEFAULT_LIMITS`)."""

    R_SFE_deg: Range | None = None
    R_SAA_deg: Range | None = None
    R_HR_deg: Range | None = None
    R_EB_deg: Range | None = None
    L_SFE_deg: Range | None = None
    L_SAA_deg: Range | None = None
    L_HR_deg: Range | None = None
    L_EB_deg: Range | None = None
    torso_yaw_deg: Range | None = None
    torso_pitch_deg: Range | None = None
    torso_roll_deg: Range | None = None
    torso_x_m: Range | None = None
    torso_y_m: Range | None = None
    torso_z_m: Range | None = None

    def to_limits(self, names: tuple[str, ...] = DOF_NAMES) -> JointLimits:
        """The limits in SI units for the DOFs ``names``."""
        overrides = {}
        for key, value in self:
            if value is None:
                continue
            dof, unit = key.rsplit("_", 1)
            scale = math.pi / 180.0 if unit == "deg" else 1.0
            overrides[dof] = (value[0] * scale, value[1] * scale)
        return JointLimits.default(names, **overrides)

