"""What a motion needs from the world (:class:`MotionContext`) and what it offers
(:class:`HumanMotion`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import mujoco
import numpy as np

from humimic.motion.avatar import AvatarGeometry, load_avatar_model
from humimic.world.names import HUMAN_PREFIX

if TYPE_CHECKING:
    from humimic.world.scene import Scene

#: Sampling rate (Hz) at which parametric motions are fitted by :class:`JointTrajectory`.
PRIMITIVE_RATE = 240.0


class HumanMotion(Protocol):
    """A motion of the avatar in its own frame; time 0 is the scenario's start."""

    sample_rate: float
    """Rate (Hz) at which to sample it for a faithful spline fit."""

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Avatar configuration ``(N, 51)`` at times ``t`` (N,), s."""
        ...

    def diagnostics(self, t: np.ndarray) -> dict[str, float]:
        """IK clamping (m) and joint-range excess (rad) over times ``t``; 0 means clean."""
        ...


@dataclass(frozen=True, eq=False)
class MotionContext:
    """Everything outside the motion config a motion may depend on."""

    T_avatar_base: np.ndarray
    """4x4 pose of the robot base (robot pelvis) in the avatar frame."""
    duration: float
    """Scenario duration (s)."""
    rng: np.random.Generator
    """The only source of randomness (tremor)."""
    T_avatar_W: np.ndarray = field(default_factory=lambda: avatar_at_start_of_W())
    """4x4 pose of the paper's frame W (:mod:`humimic.world.frames`) in the avatar frame;
    default: the person at W's start, facing the screen."""
    model: mujoco.MjModel | None = None
    """Model holding the avatar (the scene's, names prefixed ``prefix``); ``None`` loads
    ``models/avatar.xml``."""
    prefix: str = HUMAN_PREFIX
    geometry: AvatarGeometry = field(init=False, repr=False)

    def __post_init__(self) -> None:
        model, prefix = (self.model, self.prefix) if self.model is not None else (
            load_avatar_model(), "")
        object.__setattr__(self, "geometry", AvatarGeometry.from_model(model, prefix))

    @classmethod
    def from_scene(cls, scene: Scene, duration: float,
                   rng: np.random.Generator) -> MotionContext:
        """Context for ``scene``: ``T_avatar_base = T_world_avatar^-1 T_world_base``."""
        T_avatar_world = np.linalg.inv(scene.T_world_avatar)
        return cls(T_avatar_base=T_avatar_world @ scene.T_world_base,
                   T_avatar_W=T_avatar_world @ scene.T_world_W, duration=duration, rng=rng,
                   model=scene.model, prefix=HUMAN_PREFIX)

    @classmethod
    def facing_robot(cls, distance: float = 1.285, duration: float = 10.0,
                     rng: np.random.Generator | None = None) -> MotionContext:
        """A scene-free context: the robot base ``distance`` m in front of the avatar, facing it,
        at the avatar's pelvis height, and the person at the start of the paper's W, facing its
        screen (for tests and offline use)."""
        T = np.eye(4)
        T[:3, :3] = np.diag([-1.0, -1.0, 1.0])
        T[:3, 3] = [distance, 0.0, 0.981]
        return cls(T_avatar_base=T, T_avatar_W=avatar_at_start_of_W(), duration=duration,
                   rng=rng if rng is not None else np.random.default_rng(0))

    def W_to_avatar(self, xz: np.ndarray, heading_deg: np.ndarray | float = 0.0
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Floor points ``(x, z)`` in W ``(..., 2)`` and headings (deg, 0 = W's +z, positive
        to the left) -> avatar-frame ``(x, y)`` and headings (rad, about the avatar's z)."""
        xz = np.asarray(xz, float)
        p_W = np.stack([xz[..., 0], np.zeros(xz.shape[:-1]), xz[..., 1]], axis=-1)
        T = self.T_avatar_W
        p = p_W @ T[:3, :3].T + T[:3, 3]
        yaw0 = np.arctan2(T[1, 2], T[0, 2])  # W's z in the avatar frame
        return p[..., :2], yaw0 + np.radians(heading_deg)

    @property
    def R_avatar_base(self) -> np.ndarray:
        return self.T_avatar_base[:3, :3]

    @property
    def palm_direction(self) -> np.ndarray:
        """Horizontal unit vector from the avatar towards the robot (avatar frame)."""
        p = np.array([self.T_avatar_base[0, 3], self.T_avatar_base[1, 3], 0.0])
        n = np.linalg.norm(p)
        return p / n if n > 0.1 else np.array([1.0, 0.0, 0.0])


def avatar_at_start_of_W() -> np.ndarray:
    """``T_avatar_W`` for a person standing at W's start ``(0, -2.5)`` facing the screen: W's
    z is the avatar's x (forward), its x the avatar's y (left), its y up; W's origin 2.5 m
    ahead at the screen centre's height."""
    from humimic.world.frames import SCREEN_HEIGHT_M, START_XZ_W

    T = np.eye(4)
    T[:3, :3] = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    T[:3, 3] = [-START_XZ_W[1], -START_XZ_W[0], SCREEN_HEIGHT_M]
    return T
