"""The articulated body model: a skeleton, shaped parts on its segments, joint limits, and
which DOFs a tracker estimates.

A part is an :class:`Ellipsoid` or a :class:`Cone` (truncated elliptic cone; ``taper = 1`` an
elliptic cylinder) rigidly attached to a segment of :data:`humimic.bodymodel.kinematics.SEGMENTS`
at ``(R_seg_part, p_seg_part)``. A tracker estimates a subset of the 14 DOFs (``free``); the
others are *fixed* per call (one value for all particles), e.g. Menezes' 8-DOF tracker frees
the arms and takes the torso pose from a face tracker::

    body = avatar_body().with_free(ARM_DOFS["R"] + ARM_DOFS["L"])
    pose = body.forward(q_arms, fixed=torso_pose_6)      # q_arms (N, 8)
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from humimic.bodymodel.forward_kernel import segment_frames, skeleton_args
from humimic.bodymodel.kinematics import (
    DOF_NAMES,
    JOINT_SEGMENT,
    SEGMENTS,
    Skeleton,
)
from humimic.bodymodel.limits import JointLimits


@dataclass(frozen=True)
class Ellipsoid:
    """Ellipsoid with semi-axes (m) along the part frame's x, y, z, centred at its origin."""

    semi_axes: tuple[float, float, float]

    def __post_init__(self) -> None:
        if len(self.semi_axes) != 3 or min(self.semi_axes) <= 0.0:
            raise ValueError(f"ellipsoid: three semi-axes > 0 m needed, got {self.semi_axes}")


@dataclass(frozen=True)
class Cone:
    """Truncated elliptic cone along the part frame's +z: base rim at z = 0 with semi-axes
    ``a`` (x) and ``b`` (y), top rim at ``z = length`` with ``taper * (a, b)`` (m)."""

    a: float
    b: float
    length: float
    taper: float = 1.0

    def __post_init__(self) -> None:
        for name in ("a", "b", "length", "taper"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"cone: {name} must be > 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class Part:
    """A shape fixed to a skeleton segment."""

    name: str
    segment: str
    shape: Ellipsoid | Cone
    R_seg_part: np.ndarray = field(default_factory=lambda: np.eye(3))
    p_seg_part: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        if self.segment not in SEGMENTS:
            raise ValueError(f"part {self.name!r}: unknown segment {self.segment!r}; "
                             f"segments are {', '.join(SEGMENTS)}")


def cone_between(name: str, segment: str, p0, p1, a: float, b: float, taper: float = 1.0,
                 x_hint=(1.0, 0.0, 0.0)) -> Part:
    """A cone part from ``p0`` (base rim centre) to ``p1`` (top), segment coordinates (m); its
    ``a`` semi-axis lies along ``x_hint`` made perpendicular to the axis."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    z = p1 - p0
    length = float(np.linalg.norm(z))
    z /= length
    x = np.asarray(x_hint, float) - np.dot(x_hint, z) * z
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z], axis=1)
    return Part(name, segment, Cone(a, b, length, taper), R, p0)


@dataclass(frozen=True)
class Pose:
    """Posed skeletons of N particles in the reference frame."""

    q: np.ndarray
    """(N, 14) full states (:data:`DOF_NAMES`)."""
    R: np.ndarray
    """(N, S, 3, 3) ``R_ref_seg`` of :data:`SEGMENTS`."""
    p: np.ndarray
    """(N, S, 3) ``p_ref_seg`` (m): the joints at the segments' origins."""

    def joint(self, name: str) -> np.ndarray:
        """``(N, 3)`` position of a joint (``r_elbow``, ``l_wrist``, ... see
        :data:`humimic.bodymodel.kinematics.JOINT_SEGMENT`)."""
        return self.p[:, SEGMENTS.index(JOINT_SEGMENT[name])]

    def segment(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        i = SEGMENTS.index(name)
        return self.R[:, i], self.p[:, i]

    def to(self, T_frame_ref: np.ndarray) -> Pose:
        """The same pose in another frame (``T_frame_ref`` maps reference-frame points into
        it, e.g. ``T_cam_ref`` for the camera frame); ``q`` is kept as it was."""
        T = np.asarray(T_frame_ref, float)
        return Pose(self.q, T[:3, :3] @ self.R, self.p @ T[:3, :3].T + T[:3, 3])


@dataclass(frozen=True)
class PartLayout:
    """A model's parts as arrays: segment index, placement, and the shapes by kind."""

    segment: np.ndarray
    R_seg_part: np.ndarray
    p_seg_part: np.ndarray
    aligned: bool
    """Every part's frame is aligned with its segment's (``R_seg_part`` = identity)."""
    cone_idx: np.ndarray
    ellipsoid_idx: np.ndarray
    cone_shape: np.ndarray
    """(Pc, 4) ``a, b, length, taper``."""
    semi_axes: np.ndarray
    """(Pe, 3)."""


@dataclass(frozen=True, eq=False)
class BodyModel:
    """Skeleton + parts + limits; ``free`` DOFs are the tracker's state (in that order)."""

    skeleton: Skeleton
    parts: tuple[Part, ...]
    limits: JointLimits = field(default_factory=JointLimits.default)
    free: tuple[str, ...] = DOF_NAMES

    def __post_init__(self) -> None:
        unknown = [n for n in self.free if n not in DOF_NAMES]
        if unknown or len(set(self.free)) != len(self.free):
            raise ValueError(f"body model: free DOFs must be distinct names from "
                             f"{', '.join(DOF_NAMES)}; got {self.free}")
        if self.limits.names != DOF_NAMES:
            object.__setattr__(self, "limits", _complete(self.limits))
        names = [p.name for p in self.parts]
        if len(set(names)) != len(names):
            raise ValueError(f"body model: part names must be distinct, got {names}")
        idx = np.array([DOF_NAMES.index(n) for n in self.free], int)
        object.__setattr__(self, "_free_idx", idx)
        object.__setattr__(self, "_fixed_idx", np.setdiff1d(np.arange(len(DOF_NAMES)), idx))

    # ---- state layout -----------------------------------------------------------------------
    @property
    def fixed_names(self) -> tuple[str, ...]:
        return tuple(DOF_NAMES[i] for i in self._fixed_idx)

    @cached_property
    def free_limits(self) -> JointLimits:
        """Limits of the free DOFs, in state order (built once: a frozen, read-only
        :class:`JointLimits`)."""
        return self.limits.subset(self.free)

    def with_free(self, names: tuple[str, ...]) -> BodyModel:
        return replace(self, free=tuple(names))

    def with_limits(self, limits: JointLimits) -> BodyModel:
        return replace(self, limits=limits)

    def expand(self, q: np.ndarray, fixed: np.ndarray | None = None) -> np.ndarray:
        """Full states ``(N, 14)`` from free states ``q (N, len(free))`` and the fixed DOFs'
        values ``fixed (len(fixed_names),)`` (zeros if omitted)."""
        q = np.atleast_2d(np.asarray(q, float))
        if q.shape[1] != len(self.free):
            raise ValueError(f"body model: state has {q.shape[1]} values, the model's free DOFs "
                             f"are {len(self.free)}: {', '.join(self.free)}")
        full = np.zeros((len(q), len(DOF_NAMES)))
        full[:, self._free_idx] = q
        if fixed is not None and len(self._fixed_idx):
            fixed = np.asarray(fixed, float)
            if fixed.shape[-1] != len(self._fixed_idx):
                raise ValueError(f"body model: {len(self._fixed_idx)} fixed values needed "
                                 f"({', '.join(self.fixed_names)}), got {fixed.shape[-1]}")
            full[:, self._fixed_idx] = fixed
        return full

    def clamp(self, q: np.ndarray) -> np.ndarray:
        """Free states enforced to the joint limits (Menezes: clamped, not rejected)."""
        return self.free_limits.clamp(q)

    def forward(self, q: np.ndarray, fixed: np.ndarray | None = None) -> Pose:
        """Forward kinematics of free states ``q (N, len(free))`` (compiled:
        :func:`~humimic.bodymodel.forward_kernel.segment_frames`)."""
        full = self.expand(q, fixed)
        R, p = segment_frames(full, self._skeleton_args)
        return Pose(full, R, p)

    @cached_property
    def _skeleton_args(self) -> tuple:
        return skeleton_args(self.skeleton)

    # ---- parts ------------------------------------------------------------------------------
    @property
    def part_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parts)

    def part(self, name: str) -> Part:
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(f"no part {name!r}; parts are {', '.join(self.part_names)}")

    def without(self, *names: str) -> BodyModel:
        """The model without the parts ``names`` (e.g. a tracker that ignores the torso)."""
        for n in names:
            self.part(n)
        return replace(self, parts=tuple(p for p in self.parts if p.name not in names))

    def replace_part(self, part: Part) -> BodyModel:
        self.part(part.name)
        return replace(self, parts=tuple(part if p.name == part.name else p
                                         for p in self.parts))

    @cached_property
    def layout(self) -> PartLayout:
        """The parts as arrays (computed once per model)."""
        cones = [i for i, p in enumerate(self.parts) if isinstance(p.shape, Cone)]
        ells = [i for i, p in enumerate(self.parts) if not isinstance(p.shape, Cone)]
        R_sp = np.stack([p.R_seg_part for p in self.parts])
        return PartLayout(
            segment=np.array([SEGMENTS.index(p.segment) for p in self.parts], int),
            R_seg_part=R_sp, p_seg_part=np.stack([p.p_seg_part for p in self.parts]),
            aligned=bool(np.array_equal(R_sp, np.broadcast_to(np.eye(3), R_sp.shape))),
            cone_idx=np.array(cones, int), ellipsoid_idx=np.array(ells, int),
            cone_shape=np.array([[s.a, s.b, s.length, s.taper] for s in
                                 (self.parts[i].shape for i in cones)], float).reshape(-1, 4),
            semi_axes=np.array([self.parts[i].shape.semi_axes for i in ells],
                               float).reshape(-1, 3))

    def part_frames(self, pose: Pose) -> tuple[np.ndarray, np.ndarray]:
        """``R_ref_part (N, P, 3, 3)``, ``p_ref_part (N, P, 3)`` of every part."""
        lay = self.layout
        R_seg, p_seg = np.take(pose.R, lay.segment, axis=1), np.take(pose.p, lay.segment, axis=1)
        p = p_seg + (R_seg @ lay.p_seg_part[:, :, None])[..., 0]
        return (R_seg if lay.aligned else R_seg @ lay.R_seg_part), p


def _complete(limits: JointLimits) -> JointLimits:
    """Limits for all of :data:`DOF_NAMES`: the given ones, defaults for the rest."""
    base = JointLimits.default()
    lo, hi = base.lower.copy(), base.upper.copy()
    for name, a, b in zip(limits.names, limits.lower, limits.upper, strict=True):
        i = DOF_NAMES.index(name)
        lo[i], hi[i] = a, b
    return JointLimits(DOF_NAMES, lo, hi)
