"""humimic: a humanoid that watches a simulated person through its own eyes and imitates them.

Importing the package changes nothing global. Programs that render call
:func:`select_gl_backend` before anything imports ``mujoco`` (the entry points do: ``python -m
humimic.run`` and the other ``__main__`` modules); it picks a headless OpenGL backend when the
user has not set ``MUJOCO_GL`` (see :mod:`humimic._gl`).
"""

from humimic._gl import select_gl_backend

__all__ = ["select_gl_backend"]
__version__ = "0.1.0"
