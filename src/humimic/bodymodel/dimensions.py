"""Body dimensions read from compiled MuJoCo models (never typed in): the avatar's skeleton and
shapes, and DB's arm skeleton (for checking the joint convention on the robot).

The avatar's parts (:func:`avatar_parts`):

* head, hands: its ellipsoid geoms, exactly (size and offset in the head / hand frame; the
  hands are fixed to the forearms with the wrist straight);
* upper arms, forearms: its capsules as circular cylinders of the capsule's radius, centred on
  the capsule, with the same side-view area (the cylinder is ``pi r / 2`` longer than the
  capsule's segment);
* torso (``torso="ellipsoids"``, the default): its abdomen and thorax ellipsoids, exactly
  (parts ``abdomen`` and ``thorax``);
* torso (``torso="cylinder"``, Schmidt's): one elliptic cylinder standing for both: height and
  centre from the second moment of their union's front-view silhouette (an equal-variance
  rectangle), semi-axes from the front and side silhouettes' areas (``area / (2 height)``).
  It covers the avatar's trunk with IoU 0.79-0.87 (square corners against round ellipsoids).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from humimic.bodymodel.kinematics import Skeleton
from humimic.bodymodel.limits import JointLimits
from humimic.bodymodel.model import BodyModel, Ellipsoid, Part, cone_between
from humimic.motion.avatar import load_avatar_model
from humimic.paths import MODELS_DIR

#: Model part -> the avatar geoms it stands for (segmentation ground truth).
AVATAR_PART_GEOMS = {
    "torso": ("abdomen", "thorax"), "abdomen": ("abdomen",), "thorax": ("thorax",),
    "head": ("head",),
    "r_upper_arm": ("r_upper_arm",), "r_forearm": ("r_forearm",), "r_hand": ("r_hand",),
    "l_upper_arm": ("l_upper_arm",), "l_forearm": ("l_forearm",), "l_hand": ("l_hand",),
}
#: Samples per axis of the silhouette grids used to fit the torso cylinder.
_GRID = 241


def _along_minus_z(v: np.ndarray, what: str) -> float:
    if abs(v[0]) > 1e-9 or abs(v[1]) > 1e-9 or v[2] >= 0:
        raise ValueError(f"{what} must lie along -z of its parent, got {v}")
    return float(-v[2])


def skeleton_from_model(model: mujoco.MjModel, torso: str, shoulders: tuple[str, str],
                        head: str, prefix: str = "") -> Skeleton:
    """Skeleton from body offsets: ``shoulders`` (right, left upper-arm bodies) and ``head``
    children of ``torso``; each upper arm's first child body is the forearm, its first child
    the hand."""
    def body(name: str):
        return model.body(prefix + name)

    def child(b):
        ids = np.flatnonzero(model.body_parentid == b.id)
        ids = ids[ids != b.id]
        return model.body(int(ids[0]))

    up = {}
    for side, name in zip(("R", "L"), shoulders, strict=True):
        s = body(name)
        if model.body_parentid[s.id] != body(torso).id:
            raise ValueError(f"{name} is not a child of {torso}")
        up[side] = s
    fore = child(up["R"])
    hand = child(fore)
    return Skeleton(
        shoulder={side: b.pos.copy() for side, b in up.items()},
        neck=body(head).pos.copy(),
        upper_arm=_along_minus_z(fore.pos, f"{fore.name} offset"),
        forearm=_along_minus_z(hand.pos, f"{hand.name} offset"),
    )


def avatar_skeleton(model: mujoco.MjModel | None = None, prefix: str = "") -> Skeleton:
    """The avatar's skeleton (``models/avatar.xml``; or the scene's with ``prefix="human/"``)."""
    if model is None:
        model, prefix = load_avatar_model(), ""
    return skeleton_from_model(model, "chest", ("r_upper_arm", "l_upper_arm"), "head", prefix)


def db_skeleton(model: mujoco.MjModel | None = None, prefix: str = "") -> Skeleton:
    """DB's upper-body skeleton in its torso frame (``models/db_humanoid.xml``)."""
    if model is None:
        model, prefix = mujoco.MjModel.from_xml_path(str(MODELS_DIR / "db_humanoid.xml")), ""
    return skeleton_from_model(model, "torso", ("R_upper_arm", "L_upper_arm"), "head", prefix)


def _capsule_cylinder(model, geom: str, part: str, segment: str) -> Part:
    g = model.geom(geom)
    if g.type[0] != mujoco.mjtGeom.mjGEOM_CAPSULE:
        raise ValueError(f"avatar geom {geom} is not a capsule")
    r, half = float(g.size[0]), float(g.size[1])
    R = g.quat.copy()
    axis = np.empty(9)
    mujoco.mju_quat2Mat(axis, R)
    z = axis.reshape(3, 3)[:, 2]
    half_len = half + math.pi * r / 4.0  # same side-view area as the capsule
    return cone_between(part, segment, g.pos - half_len * z, g.pos + half_len * z, r, r)


def _ellipsoid(model, geom: str, part: str, segment: str) -> Part:
    g = model.geom(geom)
    if g.type[0] != mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        raise ValueError(f"avatar geom {geom} is not an ellipsoid")
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, g.quat)
    return Part(part, segment, Ellipsoid(tuple(float(s) for s in g.size)), R.reshape(3, 3),
                g.pos.copy())


def torso_cylinder(centres_z: np.ndarray, semi_axes: np.ndarray) -> tuple[float, float, float,
                                                                          float]:
    """``(z0, z1, a, b)`` of the elliptic cylinder standing for axis-aligned ellipsoids centred
    on the z axis at heights ``centres_z (K,)`` with ``semi_axes (K, 3)`` (see module doc)."""
    lo = float(np.min(centres_z - semi_axes[:, 2]))
    hi = float(np.max(centres_z + semi_axes[:, 2]))
    z = np.linspace(lo, hi, _GRID)
    areas, var_z, mean_z = [], None, None
    for axis in (0, 1):  # side view (x-z), front view (y-z)
        w = semi_axes[:, axis].max()
        h = np.linspace(-w, w, _GRID)
        hh, zz = np.meshgrid(h, z)
        inside = np.zeros_like(hh, bool)
        for cz, s in zip(centres_z, semi_axes, strict=True):
            inside |= (hh / s[axis]) ** 2 + ((zz - cz) / s[2]) ** 2 <= 1.0
        areas.append(inside.mean() * (2 * w) * (hi - lo))
        if axis == 1:
            mean_z, var_z = zz[inside].mean(), zz[inside].var()
    height = math.sqrt(12.0 * var_z)
    return (mean_z - height / 2, mean_z + height / 2, areas[0] / (2 * height),
            areas[1] / (2 * height))


TORSO_STYLES = ("ellipsoids", "cylinder")


def avatar_parts(model: mujoco.MjModel | None = None, prefix: str = "",
                 torso: str = "ellipsoids") -> tuple[Part, ...]:
    """The avatar's parts (see the module docstring), on the model's segments."""
    if torso not in TORSO_STYLES:
        raise ValueError(f"torso must be one of {TORSO_STYLES}, got {torso!r}")
    if model is None:
        model, prefix = load_avatar_model(), ""
    if torso == "ellipsoids":
        parts = [_ellipsoid(model, prefix + g, g, "torso") for g in AVATAR_PART_GEOMS["torso"]]
    else:
        trunk = [model.geom(prefix + g) for g in AVATAR_PART_GEOMS["torso"]]
        for g in trunk:
            if (g.type[0] != mujoco.mjtGeom.mjGEOM_ELLIPSOID
                    or abs(g.pos[0]) + abs(g.pos[1]) > 1e-9):
                raise ValueError(f"avatar geom {g.name} must be an ellipsoid on the chest's "
                                 "z axis")
        z0, z1, a, b = torso_cylinder(np.array([g.pos[2] for g in trunk]),
                                      np.array([g.size for g in trunk]))
        parts = [cone_between("torso", "torso", (0, 0, z0), (0, 0, z1), a, b)]
    parts.append(_ellipsoid(model, prefix + "head", "head", "head"))
    for side in ("r", "l"):
        parts += [
            _capsule_cylinder(model, f"{prefix}{side}_upper_arm", f"{side}_upper_arm",
                              f"{side}_upper_arm"),
            _capsule_cylinder(model, f"{prefix}{side}_forearm", f"{side}_forearm",
                              f"{side}_forearm"),
            _ellipsoid(model, f"{prefix}{side}_hand", f"{side}_hand", f"{side}_hand"),
        ]
    return tuple(parts)


def avatar_body(model: mujoco.MjModel | None = None, prefix: str = "",
                limits: JointLimits | None = None, torso: str = "ellipsoids") -> BodyModel:
    """The avatar as a 14-DOF body model: its skeleton, its parts (:func:`avatar_parts`; the
    torso as the avatar's two ellipsoids or, ``torso="cylinder"``, Schmidt's elliptic cylinder)
    and ``limits`` (default :data:`humimic.bodymodel.limits.DEFAULT_LIMITS`)."""
    if model is None:
        model, prefix = load_avatar_model(), ""
    return BodyModel(avatar_skeleton(model, prefix), avatar_parts(model, prefix, torso),
                     limits if limits is not None else JointLimits.default())
