"""The simulated world: the DB-like humanoid, the human avatar and the room in one MuJoCo scene."""

from humimic.world.scene import Scene, SceneOptions, build_scene

__all__ = ["Scene", "SceneOptions", "build_scene"]
