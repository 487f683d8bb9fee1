"""humimic: a humanoid that watches a simulated person through its own eyes and imitates them.

Importing the package selects a headless OpenGL backend for MuJoCo when the user has not
chosen one (see :mod:`humimic._gl`), so it must be imported before ``mujoco`` renders.
"""

from humimic._gl import select_gl_backend

select_gl_backend()

__version__ = "0.1.0"
