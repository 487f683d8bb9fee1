"""Robot commands from the wearer's estimated motion (Sugiyama & Miura, sec. V-C).

"the estimated horizontal position (x_I^W, z_I^W) is set to (y^R, x^R) of the movement
instruction, the estimated pan and tilt angles of the orientation q_I^W is set to the head
rotation instruction, and the estimated arm position p_A^I is set to the arm motion instruction
[...] The new command is issued when the previous command finished and the following conditions
are fulfilled: the movement distance is larger than 0.5 [m] in the longitudinal direction and
1.0 [m] in the lateral direction for the movement, the sum of the pan and tilt moving angles is
larger than 5 [deg] for the head rotation, and the distance of the arm motion is larger than
0.05 [m] for the arm motion."

Our readings, where the text leaves a choice:

* **Movement**: the robot's frame R has x = W's z (forward) and y = W's x (left) (Fig. 6); its
  origin is the robot's start and the wearer's start maps onto it, so the robot moves by the
  wearer's displacement since the start, ``(x_R, y_R) = (dz_W, dx_W)`` (taking (x_I, z_I) as
  absolute coordinates would send the robot 2.5 m back at once).
* **Thresholds**: a movement goes out when the target has moved more than 0.5 m along x_R
  *or* 1.0 m along y_R from the last movement's target ("and" lists the two limits: requiring
  both would never follow a walk straight ahead); "the previous command" is the previous one
  of the same kind (base, head and arm are separate actuators).
* **Head**: pan = the optical axis' azimuth about W's vertical (left positive), tilt = its
  angle below the horizontal (down positive): the robot's ``B_HR`` and ``B_HN``.
* **Arm**: ``p_A^I`` is the remote relative to the head; it is taken into W's axes with the
  head's orientation (so the robot's own head tilt does not move its hand), then into R's, and
  placed relative to the robot's eyes at their start pose: the robot holds its right hand where
  the wearer holds the remote, relative to the head.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: R's axes (x forward, y left, z up) from the paper's W's (x left, y up, z forward).
R_R_W = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
KINDS = ("move", "head", "arm")


def movement_target(p_head_W: np.ndarray, p_start_W: np.ndarray) -> np.ndarray:
    """``(x_R, y_R)`` (m): the wearer's horizontal displacement since the start, in R."""
    d = np.asarray(p_head_W, float) - np.asarray(p_start_W, float)
    return np.array([d[2], d[0]])


def head_angles(R_W_I: np.ndarray) -> np.ndarray:
    """``(pan, tilt)`` (rad) of the head camera's optical axis in W: azimuth to the left of W's
    z, angle below the horizontal."""
    z = R_W_I[:, 2]
    return np.array([np.arctan2(z[0], z[2]), np.arctan2(-z[1], np.hypot(z[0], z[2]))])


def arm_target(p_A_I: np.ndarray, R_W_I: np.ndarray, p_eyes_base: np.ndarray) -> np.ndarray:
    """The right palm's target (m) in the robot's base frame: the remote relative to the head,
    in W's axes (``R_W_I p_A^I``), in R's, from the robot's eyes ``p_eyes_base``."""
    return np.asarray(p_eyes_base, float) + R_R_W @ (R_W_I @ np.asarray(p_A_I, float))


@dataclass(frozen=True)
class Thresholds:
    """Sugiyama sec. V-C's conditions for a new command."""

    longitudinal_m: float = 0.5
    lateral_m: float = 1.0
    head_deg: float = 5.0
    arm_m: float = 0.05


def exceeds(kind: str, target: np.ndarray, last: np.ndarray, th: Thresholds) -> bool:
    """Whether ``target`` is far enough from the ``last`` issued one for a new command."""
    d = np.abs(np.asarray(target, float) - np.asarray(last, float))
    if kind == "move":
        return bool(d[0] > th.longitudinal_m or d[1] > th.lateral_m)
    if kind == "head":
        return bool(np.degrees(d[0] + d[1]) > th.head_deg)
    if kind == "arm":
        return bool(np.linalg.norm(d) > th.arm_m)
    raise ValueError(f"unknown command kind {kind!r}; kinds: {', '.join(KINDS)}")


@dataclass
class CommandGate:
    """Per kind: the last issued target and whether its execution has finished."""

    thresholds: Thresholds = field(default_factory=Thresholds)
    last: dict = field(default_factory=dict)
    busy: dict = field(default_factory=dict)

    def start(self, kind: str, target: np.ndarray) -> None:
        """The robot's state the commands are measured from (nothing is issued)."""
        self.last[kind] = np.asarray(target, float).copy()
        self.busy[kind] = False

    def offer(self, kind: str, target: np.ndarray) -> bool:
        """Whether ``target`` goes out now (then it becomes the last, and the kind busy)."""
        if kind not in self.last:
            raise KeyError(f"command kind {kind!r} not started")
        if self.busy[kind] or not exceeds(kind, target, self.last[kind], self.thresholds):
            return False
        self.last[kind] = np.asarray(target, float).copy()
        self.busy[kind] = True
        return True

    def done(self, kind: str) -> None:
        self.busy[kind] = False
