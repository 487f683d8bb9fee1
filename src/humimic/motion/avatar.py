"""The avatar's configuration layout (the 51-vector) and its segment geometry, read from MuJoCo.

Layout: ``qpos`` is the avatar's contiguous block in :data:`humimic.world.names.HUMAN_JOINTS`
order (slides: 1 value, m; hinges: 1 value, rad; balls: a unit quaternion ``[w, x, y, z]``
relative to the parent body, MuJoCo's convention); ``qvel``/``qacc`` have 1 DOF per slide/hinge
and 3 per ball (angular velocity in the child body's frame). 51 positions, 40 DOF.

Geometry (:class:`AvatarGeometry`) is read from the compiled model (``models/avatar.xml`` alone
or the scene with prefix ``human/``), so the IK, the retargeting and MuJoCo's FK agree exactly.
All vectors are in the avatar frame's axes (x forward, y left, z up) at the zero pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from humimic.motion import quat
from humimic.paths import MODELS_DIR
from humimic.world.names import HUMAN_JOINTS

SIDES = ("r", "l")
#: The avatar's rigid segments (bodies) that a motion-capture skeleton drives.
SEGMENTS = ("pelvis", "chest", "head", "r_upper_arm", "r_forearm", "r_hand", "l_upper_arm",
            "l_forearm", "l_hand", "r_thigh", "r_shank", "r_foot", "l_thigh", "l_shank",
            "l_foot")
JOINT_TYPES: dict[str, str] = dict(HUMAN_JOINTS)


def _layout() -> tuple[dict[str, slice], dict[str, slice], int, int]:
    qpos, dof, iq, iv = {}, {}, 0, 0
    for name, kind in HUMAN_JOINTS:
        nq, nv = (4, 3) if kind == "ball" else (1, 1)
        qpos[name] = slice(iq, iq + nq)
        dof[name] = slice(iv, iv + nv)
        iq, iv = iq + nq, iv + nv
    return qpos, dof, iq, iv


#: joint name -> slice into the avatar's qpos (51) / qvel (40).
QPOS_SLICES, DOF_SLICES, NQ, NV = _layout()
BALL_JOINTS = tuple(n for n, k in HUMAN_JOINTS if k == "ball")
SCALAR_JOINTS = tuple(n for n, k in HUMAN_JOINTS if k != "ball")


def zero_qpos(n: int = 1) -> np.ndarray:
    """``(n, 51)`` zero pose: slides and hinges 0, every ball joint the identity quaternion."""
    q = np.zeros((n, NQ))
    for name in BALL_JOINTS:
        q[:, QPOS_SLICES[name].start] = 1.0
    return q


def load_avatar_model() -> mujoco.MjModel:
    """The avatar alone (``models/avatar.xml``, unprefixed names, avatar frame = world)."""
    return mujoco.MjModel.from_xml_path(str(MODELS_DIR / "avatar.xml"))


@dataclass(frozen=True)
class AvatarGeometry:
    """Segment offsets of the avatar (m). Offsets are parent-frame vectors at the zero pose."""

    pelvis: np.ndarray
    """Pelvis (root) origin in the avatar frame when the root slides are zero."""
    chest: np.ndarray
    """Chest (spine joint) in the pelvis frame."""
    neck: np.ndarray
    """Head body (neck joint) in the chest frame."""
    head_site: np.ndarray
    """Head centre site in the head frame."""
    head_top: np.ndarray
    """Top of the head (the head ellipsoid's apex) in the head frame."""
    shoulder: dict[str, np.ndarray]
    """Shoulder joint per side ``r``/``l`` in the chest frame."""
    upper_arm: float
    """Shoulder to elbow (along the upper arm's -z)."""
    forearm: float
    """Elbow to wrist (along the forearm's -z)."""
    palm: float
    """Wrist to palm-centre site (along the hand's -z)."""
    hip: dict[str, np.ndarray]
    """Hip joint per side in the pelvis frame."""
    thigh: float
    shank: float
    sole: float
    """Ankle joint height above the sole (the foot box's bottom)."""
    sole_corners: np.ndarray
    """(4, 3) bottom corners of the foot box in the foot frame (same for both feet)."""
    ranges: dict[str, tuple[float, float]]
    """Joint ranges from the model (hinge: [lo, hi] rad; ball: [0, max angle] rad)."""

    @classmethod
    def from_model(cls, model: mujoco.MjModel, prefix: str = "") -> AvatarGeometry:
        def pos(body: str) -> np.ndarray:
            return model.body(prefix + body).pos.copy()

        def along_minus_z(v: np.ndarray, what: str) -> float:
            if abs(v[0]) > 1e-9 or abs(v[1]) > 1e-9 or v[2] >= 0:
                raise ValueError(f"avatar model: {what} must lie along -z, got {v}")
            return float(-v[2])

        upper_arm = along_minus_z(pos("r_forearm"), "elbow offset")
        forearm = along_minus_z(pos("r_hand"), "wrist offset")
        palm = along_minus_z(model.site(prefix + "r_hand").pos.copy(), "palm site")
        thigh = along_minus_z(pos("r_shank"), "knee offset")
        shank = along_minus_z(pos("r_foot"), "ankle offset")
        foot = model.geom(prefix + "r_foot")
        sole = float(-(foot.pos[2] - foot.size[2]))
        sx, sy, sz = foot.size
        sole_corners = foot.pos + np.array([[x, y, -sz] for x in (-sx, sx) for y in (-sy, sy)])
        head = model.geom(prefix + "head")
        ranges = {}
        for name, _ in HUMAN_JOINTS:
            j = model.joint(prefix + name)
            ranges[name] = (float(j.range[0]), float(j.range[1])) if j.limited[0] else (
                -np.inf, np.inf)
        return cls(
            pelvis=pos("pelvis"),
            chest=pos("chest"),
            neck=pos("head"),
            head_site=model.site(prefix + "head").pos.copy(),
            head_top=head.pos + np.array([0.0, 0.0, head.size[2]]),
            shoulder={"r": pos("r_upper_arm"), "l": pos("l_upper_arm")},
            upper_arm=upper_arm,
            forearm=forearm,
            palm=palm,
            hip={"r": pos("r_thigh"), "l": pos("l_thigh")},
            thigh=thigh,
            shank=shank,
            sole=sole,
            sole_corners=sole_corners,
            ranges=ranges,
        )

    @property
    def head_zero(self) -> np.ndarray:
        """Head-centre site in the avatar frame at the zero pose."""
        return self.pelvis + self.chest + self.neck + self.head_site

    @property
    def height(self) -> float:
        """Standing height: floor to the top of the head at the zero pose (1.75 m)."""
        return float((self.pelvis + self.chest + self.neck + self.head_top)[2])


def ball(qpos: np.ndarray, name: str) -> np.ndarray:
    """The ``(N, 4)`` quaternion block of ball joint ``name`` (a view)."""
    return qpos[..., QPOS_SLICES[name]]


def root_pose(qpos: np.ndarray, g: AvatarGeometry) -> tuple[np.ndarray, np.ndarray]:
    """``R_avatar_pelvis (N,3,3)``, ``p_avatar_pelvis (N,3)`` from the root slides and ball."""
    p = g.pelvis + qpos[:, 0:3]
    return quat.to_matrix(ball(qpos, "root_rot")), p


def chest_pose(qpos: np.ndarray, g: AvatarGeometry) -> tuple[np.ndarray, np.ndarray]:
    """``R_avatar_chest``, ``p_avatar_chest`` (the spine joint's child frame)."""
    R_p, p_p = root_pose(qpos, g)
    return R_p @ quat.to_matrix(ball(qpos, "spine")), p_p + R_p @ g.chest


def head_site_position(qpos: np.ndarray, g: AvatarGeometry) -> np.ndarray:
    """Head-centre site in the avatar frame."""
    R_c, p_c = chest_pose(qpos, g)
    R_h = R_c @ quat.to_matrix(ball(qpos, "neck"))
    return p_c + R_c @ g.neck + R_h @ g.head_site


def shoulder_position(qpos: np.ndarray, g: AvatarGeometry, side: str) -> np.ndarray:
    """Shoulder joint of ``side`` (``r``/``l``) in the avatar frame."""
    R_c, p_c = chest_pose(qpos, g)
    return p_c + R_c @ g.shoulder[side]


def range_violations(qpos: np.ndarray, g: AvatarGeometry) -> dict[str, float]:
    """Largest excess (rad) beyond each joint's model range over the samples (0 if inside)."""
    out = {}
    for name, kind in HUMAN_JOINTS:
        lo, hi = g.ranges[name]
        if kind == "ball":
            a = quat.angle(ball(qpos, name))
            excess = np.max(a - hi) if np.isfinite(hi) else 0.0
        else:
            v = qpos[:, QPOS_SLICES[name].start]
            excess = max(np.max(lo - v), np.max(v - hi)) if np.isfinite(hi) else 0.0
        out[name] = float(max(excess, 0.0))
    return out
