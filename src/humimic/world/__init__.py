"""The simulated world: the DB-like humanoid, the human avatar and the room in one MuJoCo scene.

``Scene``, ``SceneOptions`` and ``build_scene`` (:mod:`humimic.world.scene`) are loaded on first
use, so that importing a light submodule (names, robot limits, textures) does not import
``mujoco`` before an entry point has chosen its OpenGL backend.
"""

__all__ = ["Scene", "SceneOptions", "build_scene"]


def __getattr__(name: str):
    if name in __all__:
        from humimic.world import scene

        return getattr(scene, name)
    raise AttributeError(f"module 'humimic.world' has no attribute {name!r}")
