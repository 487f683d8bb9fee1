"""Pick MuJoCo's OpenGL backend before ``mujoco`` is imported (entry points call
:func:`select_gl_backend`; importing humimic changes no environment variable).

MuJoCo reads ``MUJOCO_GL`` once, at import. With no display (a server, CI) the default GLFW
backend cannot open a window, so we choose EGL (Mesa renders on the CPU) and fall back to
OSMesa. A value the user set is always respected.

With EGL on Mesa's llvmpipe (a CPU rasterizer) we also set ``LP_NUM_THREADS=0`` unless the
user chose: rasterizing in the calling thread avoids waking llvmpipe's thread pool for every
small frame (measured: same speed for the world loop, 10-20 % faster and steadier for the closed
loop, whose perception worker then has the second core to itself; re-measured with the worker
in a process: 3.25x real time against 2.9x with 1 and 3.1x with 2 rasterizer threads).
"""

from __future__ import annotations

import ctypes.util
import os


def headless_backend() -> str | None:
    """The first headless OpenGL backend whose library is installed: ``egl``, else ``osmesa``."""
    for backend, lib in (("egl", "EGL"), ("osmesa", "OSMesa")):
        if ctypes.util.find_library(lib):
            return backend
    return None


def select_gl_backend() -> str | None:
    """Set ``MUJOCO_GL`` (and ``PYOPENGL_PLATFORM``, ``LP_NUM_THREADS``) if the user has not and
    there is no display; return the backend in use (``None``: MuJoCo's default).

    Entry points call this before anything imports ``mujoco``, which reads ``MUJOCO_GL`` once,
    at import; importing :mod:`humimic` does not.
    """
    if os.environ.get("MUJOCO_GL"):
        return os.environ["MUJOCO_GL"]
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return None  # a display exists: MuJoCo's default (GLFW) works
    backend = headless_backend()
    if backend is not None:
        os.environ["MUJOCO_GL"] = backend
        os.environ.setdefault("PYOPENGL_PLATFORM", backend)
        os.environ.setdefault("LP_NUM_THREADS", "0")
    return backend
