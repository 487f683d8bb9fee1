"""BVH -> avatar configuration by rotation retargeting.

1. Axes: BVH files here are Y-up with the subject facing +Z in the rest pose, so BVH (X, Y, Z)
   = avatar (y, z, x): ``v_avatar = M v_bvh``, ``R_avatar = M R_bvh M^T``.
2. Segment orientations: each avatar segment takes the global orientation of its BVH joint
   times a constant rest offset ``C``, computed once from the BVH rest pose (all channels 0,
   typically a T-pose) against the avatar's zero pose (arms down): for a limb ``C`` is the
   minimal rotation taking the avatar's bone direction (-z) onto the BVH rest bone direction,
   so a T-pose arm maps to a horizontal arm, palm down; torso, head and feet use ``C = I``.
3. Joints: balls are ``local = parent^-1 child``. For an elbow (knee) the upper-arm (thigh)
   frame is rebuilt from the upper-arm and forearm directions so the forearm lies exactly in
   the hinge plane (flexion = the angle between them, >= 0); near a straight limb the plane
   blends into the BVH's own twist (:data:`STRAIGHT_BLEND`). The residual twist goes to the
   wrist (ankle), which then reproduces the BVH hand (foot) orientation exactly.
4. Root: the midpoint of the BVH hip joints (the avatar's pelvis origin is on the hip-joint
   line; CMU's Hips root is 12 cm higher), scaled by ``scale``, by default the ratio of the
   avatar's leg length to the BVH's (hip line to sole, standing): the root's motion comes
   from the legs, so this keeps stance feet on the floor and strides consistent. (The
   skeleton itself takes the avatar's proportions; the CMU subject's legs are relatively
   longer, so a height-based scale, 7 % larger here, would float the feet.) Turned about the
   vertical so the person faces the avatar's +x at the clip's start (``face_robot``), centred
   horizontally at the start, lifted so the feet stand on the floor: the
   :data:`FLOOR_PERCENTILE` percentile over the clip of the per-frame lowest foot-box corner
   is put at z = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, filtfilt

from humimic.motion import quat
from humimic.motion.avatar import BALL_JOINTS, QPOS_SLICES, SEGMENTS, AvatarGeometry
from humimic.motion.bvh import (
    BVH,
    BVHError,
    end_site_positions,
    forward_kinematics,
    rest_pose,
)

#: BVH (X, Y, Z) -> avatar axes for Y-up, +Z-forward files (CMU/MotionBuilder).
M_AVATAR_BVH = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
#: Avatar segment -> BVH joint, CMU / MotionBuilder names.
CMU_JOINT_MAP = {
    "pelvis": "Hips", "chest": "Spine1", "head": "Head",
    "r_upper_arm": "RightArm", "r_forearm": "RightForeArm", "r_hand": "RightHand",
    "l_upper_arm": "LeftArm", "l_forearm": "LeftForeArm", "l_hand": "LeftHand",
    "r_thigh": "RightUpLeg", "r_shank": "RightLeg", "r_foot": "RightFoot",
    "l_thigh": "LeftUpLeg", "l_shank": "LeftLeg", "l_foot": "LeftFoot",
}
#: Weight of the BVH's own upper-arm / thigh twist in the hinge-plane normal (vs sin(flexion)).
STRAIGHT_BLEND = 0.05
#: Percentile of the per-frame lowest foot point put on the floor (the minimum would be set by
#: brief toe-down poses, which the rigid avatar foot cannot take without its corner dipping).
FLOOR_PERCENTILE = 5.0
_Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Retargeted:
    """The clip on the avatar: one configuration per BVH frame, and the similarity transform
    ``p_avatar = R_yaw (scale M p_bvh) + offset`` used for the root."""

    qpos: np.ndarray
    """(F, 51)"""
    frame_time: float
    scale: float
    """Metres per BVH unit."""
    R_yaw: np.ndarray
    """3x3 heading correction (about the avatar's z) applied after ``M``."""
    offset: np.ndarray
    """(3,) translation (m) applied last."""


def bvh_body_lengths(bvh: BVH, jmap: dict[str, str]) -> tuple[float, float]:
    """``(upper, leg)`` of the BVH skeleton standing straight, in BVH units: head top (the Head
    joint's End Site, else the Head joint) above the hip joints in the rest pose, and per leg
    thigh + shank + the ankle's height above the foot's lowest point (mean of both legs)."""
    R0, p0 = rest_pose(bvh)
    up = lambda v: float((M_AVATAR_BVH @ v)[2])  # noqa: E731
    ends = end_site_positions(bvh, R0[None], p0[None])
    head = bvh.index(jmap["head"])
    top = max(up(p0[head]), *(up(e[0]) for k, e in ends.items() if _descends(bvh, k, head)))
    hip_line, legs = [], []
    for s in "rl":
        hip, knee, ankle = (bvh.index(jmap[f"{s}_{seg}"]) for seg in ("thigh", "shank", "foot"))
        foot_pts = [up(p0[k]) for k in range(len(bvh.joints)) if _descends(bvh, k, ankle)]
        foot_pts += [up(e[0]) for k, e in ends.items() if _descends(bvh, k, ankle)]
        hip_line.append(up(p0[hip]))
        legs.append(np.linalg.norm(p0[knee] - p0[hip]) + np.linalg.norm(p0[ankle] - p0[knee])
                    + up(p0[ankle]) - min(foot_pts))
    return top - float(np.mean(hip_line)), float(np.mean(legs))


def _descends(bvh: BVH, joint: int | str, ancestor: int) -> bool:
    """``joint`` (index or name) is ``ancestor`` or below it."""
    j = bvh.index(joint) if isinstance(joint, str) else joint
    while j >= 0:
        if j == ancestor:
            return True
        j = bvh.joints[j].parent
    return False


def rest_offsets(bvh: BVH, jmap: dict[str, str]) -> dict[str, np.ndarray]:
    """Constant rest offsets ``C`` per segment (avatar axes): limbs from the rest bone
    directions (the hand uses the forearm's), torso/head/feet identity."""
    _, p0 = rest_pose(bvh)
    C = {seg: np.eye(3) for seg in jmap}
    for s in "rl":
        for seg, child in (("upper_arm", "forearm"), ("forearm", "hand"),
                           ("thigh", "shank"), ("shank", "foot")):
            bone = M_AVATAR_BVH @ (p0[bvh.index(jmap[f"{s}_{child}"])]
                                   - p0[bvh.index(jmap[f"{s}_{seg}"])])
            C[f"{s}_{seg}"] = quat.swing(-_Z, bone)
        C[f"{s}_hand"] = C[f"{s}_forearm"]
    return C


def hinge_limb(R_upper: np.ndarray, R_lower: np.ndarray, flex_sign: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Rebuilt upper-segment frame and hinge flexion for a two-segment limb.

    ``flex_sign`` is -1 for an elbow (axis -y: flexion turns -z towards +x) and +1 for a knee
    (axis +y: towards -x). Returns ``R_upper'`` (N, 3, 3) and ``theta`` (N,).
    """
    u = -R_upper[:, :, 2]
    f = -R_lower[:, :, 2]
    y_ref = R_upper[:, :, 1]
    n = np.cross(f, u) if flex_sign < 0 else np.cross(u, f)
    R = quat.frame_from_zy(-u, n + STRAIGHT_BLEND * y_ref)
    f_loc = np.einsum("nji,nj->ni", R, f)
    theta = np.arctan2(-flex_sign * f_loc[:, 0], -f_loc[:, 2])
    return R, theta


def retarget(bvh: BVH, g: AvatarGeometry, jmap: dict[str, str] | None = None,
             scale: float | None = None, face_robot: bool = True,
             start_frame: int = 0, smoothing_hz: float | None = None) -> Retargeted:
    """Avatar configuration for every frame of ``bvh`` (see the module docstring), low-passed
    at ``smoothing_hz`` (clip time) if given."""
    jmap = {**CMU_JOINT_MAP, **(jmap or {})}
    if set(jmap) != set(SEGMENTS):
        raise ValueError(f"joint_map segments must be among {', '.join(SEGMENTS)}")
    if bvh.n_frames == 0:
        raise BVHError(f"{bvh.source}: the clip has no frames")
    for name in jmap.values():
        bvh.index(name)  # a BVHError naming the missing joint
    if scale is None:
        scale = g.pelvis[2] / bvh_body_lengths(bvh, jmap)[1]
    R_b, p_b = forward_kinematics(bvh)
    M = M_AVATAR_BVH
    C = rest_offsets(bvh, jmap)
    R = {seg: M @ R_b[:, bvh.index(name)] @ M.T @ C[seg] for seg, name in jmap.items()}

    fwd = R["pelvis"][start_frame, :, 0]
    yaw = np.arctan2(fwd[1], fwd[0]) if face_robot else 0.0
    R_yaw = quat.rot_z(-yaw)
    R = {seg: R_yaw @ r for seg, r in R.items()}
    # The avatar's pelvis origin is on the hip-joint line: the midpoint of the BVH thighs'
    # joints (CMU's Hips root sits about 12 cm higher, at the sacrum).
    p_hip_line = 0.5 * (p_b[:, bvh.index(jmap["r_thigh"])] + p_b[:, bvh.index(jmap["l_thigh"])])
    p_hips = scale * (p_hip_line @ (R_yaw @ M).T)

    q = np.zeros((len(p_b), 51))

    def put(joint: str, R_parent: np.ndarray, R_child: np.ndarray) -> None:
        q[:, QPOS_SLICES[joint]] = quat.hemisphere_continuous(
            quat.from_matrix(np.swapaxes(R_parent, -1, -2) @ R_child))

    q[:, QPOS_SLICES["root_rot"]] = quat.hemisphere_continuous(quat.from_matrix(R["pelvis"]))
    put("spine", R["pelvis"], R["chest"])
    put("neck", R["chest"], R["head"])
    for s in "rl":
        R_s, th = hinge_limb(R[f"{s}_upper_arm"], R[f"{s}_forearm"], -1.0)
        put(f"{s}_shoulder", R["chest"], R_s)
        q[:, QPOS_SLICES[f"{s}_elbow"].start] = th
        put(f"{s}_wrist", R_s @ quat.rot_y(-th), R[f"{s}_hand"])
        R_t, th = hinge_limb(R[f"{s}_thigh"], R[f"{s}_shank"], 1.0)
        put(f"{s}_hip", R["pelvis"], R_t)
        q[:, QPOS_SLICES[f"{s}_knee"].start] = th
        put(f"{s}_ankle", R_t @ quat.rot_y(th), R[f"{s}_foot"])

    if smoothing_hz is not None:
        q = lowpass_configuration(q, bvh.frame_time, smoothing_hz)
        p_hips = lowpass(p_hips, bvh.frame_time, smoothing_hz)

    # Root: centre horizontally at the start frame; feet on the floor in stance.
    offset = -p_hips[start_frame] * np.array([1.0, 1.0, 0.0])
    p_pelvis = p_hips + offset
    lowest = np.minimum(*(_sole_height(q, p_pelvis, g, s) for s in "rl"))
    offset[2] = -float(np.percentile(lowest, FLOOR_PERCENTILE))
    q[:, 0:3] = p_hips + offset - g.pelvis
    return Retargeted(q, bvh.frame_time, float(scale), R_yaw, offset)


def lowpass(x: np.ndarray, frame_time: float, cutoff_hz: float) -> np.ndarray:
    """Zero-phase low-pass along axis 0: a 2nd-order Butterworth run forwards and backwards
    (Winter, *Biomechanics and Motor Control of Human Movement*, ch. 2, filters human motion
    capture at about 6 Hz). Cut-offs at or above Nyquist, or very short inputs, return a copy."""
    nyquist = 0.5 / frame_time
    if cutoff_hz >= nyquist or len(x) < 10:
        return np.array(x, float)
    b, a = butter(2, cutoff_hz / nyquist)
    return filtfilt(b, a, x, axis=0, padtype="odd", padlen=min(len(x) - 1, 30))


def lowpass_configuration(qpos: np.ndarray, frame_time: float, cutoff_hz: float) -> np.ndarray:
    """:func:`lowpass` of a configuration sequence (F, 51); quaternions are filtered per
    component (they must be hemisphere-continuous) and renormalised."""
    out = lowpass(qpos, frame_time, cutoff_hz)
    for j in BALL_JOINTS:
        s = QPOS_SLICES[j]
        out[:, s] = quat.normalize(out[:, s])
    return out


def _sole_height(q: np.ndarray, p_pelvis: np.ndarray, g: AvatarGeometry, s: str) -> np.ndarray:
    """Height of the lowest foot-box corner of side ``s`` (avatar FK of the leg)."""
    R_p = quat.to_matrix(q[:, QPOS_SLICES["root_rot"]])
    R_t = R_p @ quat.to_matrix(q[:, QPOS_SLICES[f"{s}_hip"]])
    R_sh = R_t @ quat.rot_y(q[:, QPOS_SLICES[f"{s}_knee"].start])
    R_f = R_sh @ quat.to_matrix(q[:, QPOS_SLICES[f"{s}_ankle"]])
    ankle = (p_pelvis + R_p @ g.hip[s] + R_t @ np.array([0, 0, -g.thigh])
             + R_sh @ np.array([0, 0, -g.shank]))
    corners = ankle[:, None] + np.einsum("nij,kj->nki", R_f, g.sole_corners)
    return np.min(corners[..., 2], axis=1)
