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
        T_avatar_base = np.linalg.inv(scene.T_world_avatar) @ scene.T_world_base
        return cls(T_avatar_base=T_avatar_base, duration=duration, rng=rng, model=scene.model,
                   prefix=HUMAN_PREFIX)

    @classmethod
    def facing_robot(cls, distance: float = 1.285, duration: float = 10.0,
                     rng: np.random.Generator | None = None) -> MotionContext:
        """A scene-free context: the robot base ``distance`` m in front of the avatar, facing it,
        at the avatar's pelvis height (for tests and offline use)."""
        T = np.eye(4)
        T[:3, :3] = np.diag([-1.0, -1.0, 1.0])
        T[:3, 3] = [distance, 0.0, 0.981]
        return cls(T_avatar_base=T, duration=duration,
                   rng=rng if rng is not None else np.random.default_rng(0))

    @property
    def R_avatar_base(self) -> np.ndarray:
        return self.T_avatar_base[:3, :3]

    @property
    def palm_direction(self) -> np.ndarray:
        """Horizontal unit vector from the avatar towards the robot (avatar frame)."""
        p = np.array([self.T_avatar_base[0, 3], self.T_avatar_base[1, 3], 0.0])
        n = np.linalg.norm(p)
        return p / n if n > 0.1 else np.array([1.0, 0.0, 0.0])
