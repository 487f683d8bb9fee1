"""Targets -> avatar configuration: joint values, then head placement, then the arms by IK."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from humimic.motion import quat
from humimic.motion.arm_ik import ArmIKResult, solve_arm
from humimic.motion.avatar import (
    JOINT_TYPES,
    QPOS_SLICES,
    AvatarGeometry,
    chest_pose,
    range_violations,
    zero_qpos,
)
from humimic.motion.body_ik import place_head

HAND_SIDES = {"right_hand": "r", "left_hand": "l"}


@dataclass
class PoseTargets:
    """Per-sample targets (avatar frame, m): ``(N, 3)`` arrays or ``None``; joint values
    ``{name: (N,) or (N, 3) rotation vectors}``."""

    right_hand: np.ndarray | None = None
    left_hand: np.ndarray | None = None
    head: np.ndarray | None = None
    joints: dict[str, np.ndarray] = field(default_factory=dict)


def solve_pose(n: int, targets: PoseTargets, g: AvatarGeometry, head_lean: float = 0.25,
               palm_dir: np.ndarray | dict[str, np.ndarray] | None = None
               ) -> tuple[np.ndarray, dict[str, ArmIKResult]]:
    """``(N, 51)`` configuration meeting ``targets`` and the arm IK results per hand target.

    Order: explicit joint values; the head target (torso lean + body shift); the palm targets by
    arm IK on the resulting chest pose. Arms without a target keep their joint values (zero:
    hanging). ``palm_dir`` (avatar frame, (3,) or (N, 3)) is where the palms face, or a dict
    ``{"right_hand": ..., "left_hand": ...}`` per hand.
    """
    q = zero_qpos(n)
    for name, value in targets.joints.items():
        v = np.asarray(value, float)
        if JOINT_TYPES[name] == "ball":
            q[:, QPOS_SLICES[name]] = quat.from_rotvec(np.broadcast_to(v, (n, 3)))
        else:
            q[:, QPOS_SLICES[name].start] = np.broadcast_to(v, (n,))
    if targets.head is not None:
        q = place_head(q, targets.head, head_lean, g)
    R_c, p_c = chest_pose(q, g)
    results = {}
    for key, side in HAND_SIDES.items():
        p = getattr(targets, key)
        if p is None:
            continue
        d = palm_dir.get(key) if isinstance(palm_dir, dict) else palm_dir
        res = solve_arm(side, np.broadcast_to(p, (n, 3)), R_c, p_c, g, d)
        q[:, QPOS_SLICES[f"{side}_shoulder"]] = res.q_shoulder
        q[:, QPOS_SLICES[f"{side}_elbow"].start] = res.elbow
        q[:, QPOS_SLICES[f"{side}_wrist"]] = res.q_wrist
        results[key] = res
    return q, results


def pose_diagnostics(q: np.ndarray, ik: dict[str, ArmIKResult],
                     g: AvatarGeometry) -> dict[str, float]:
    """``{"<hand>_clamp_m": worst IK clamp, "range_<joint>_rad": worst excess}`` (non-zero only)."""
    out = {f"{k}_clamp_m": float(np.max(r.clamp_distance)) for k, r in ik.items()}
    out.update({f"range_{j}_rad": v for j, v in range_violations(q, g).items() if v > 0})
    return {k: v for k, v in out.items() if v > 0}
