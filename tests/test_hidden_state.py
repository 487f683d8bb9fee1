"""No hidden global state (issue 10): importing humimic changes no environment variable and no
matplotlib backend; entry points choose MuJoCo's OpenGL backend explicitly, respecting the
user's; a camera rig never writes the shared MuJoCo model; pixel noise never touches OpenCV's
per-thread random generator."""

from __future__ import annotations

import copy
import math
import os
import subprocess
import sys

import cv2
import mujoco
import numpy as np
import pytest
from scipy.stats import norm

from humimic import select_gl_backend
from humimic._gl import headless_backend
from humimic.sensors.cameras import CameraRig, CameraSpec, add_pixel_noise, noise_table
from humimic.world.scene import SceneOptions, build_scene

PROBE = """
import os
import matplotlib
matplotlib.use("svg")
import humimic
after_import = os.environ.get("MUJOCO_GL")
import humimic.run  # the entry point (it imports the report and the plots too)
import mujoco
print(after_import, os.environ.get("MUJOCO_GL"), mujoco.GLContext.__module__,
      matplotlib.get_backend())
"""


def test_import_changes_nothing_and_the_entry_point_selects_the_backend():
    env = {k: v for k, v in os.environ.items()
           if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")}
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True,
                         text=True, timeout=120, check=True)
    after_import, after_entry, gl_module, backend = out.stdout.split()
    assert after_import == "None"  # import humimic: environment untouched
    assert after_entry == str(headless_backend())  # egl here
    assert gl_module == f"mujoco.{after_entry}"  # chosen before mujoco was imported
    assert backend == "svg"  # nothing called matplotlib.use
    assert "GLFW" not in out.stderr


def test_select_gl_backend_respects_the_users_choice(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.delenv("PYOPENGL_PLATFORM", raising=False)
    assert select_gl_backend() == "osmesa"
    assert os.environ["MUJOCO_GL"] == "osmesa" and "PYOPENGL_PLATFORM" not in os.environ
    monkeypatch.delenv("MUJOCO_GL")
    monkeypatch.setenv("DISPLAY", ":0")  # a display: MuJoCo's default (GLFW), nothing set
    assert select_gl_backend() is None and "MUJOCO_GL" not in os.environ


@pytest.fixture(scope="module")
def scene():
    s = build_scene(SceneOptions())
    mujoco.mj_forward(s.model, s.data)
    return s


def _model_state(m) -> tuple:
    g = m.vis.global_
    return (m.cam_fovy.copy(), m.geom_group.copy(), g.offwidth, g.offheight)


def test_camera_rig_renders_without_writing_the_model(scene):
    """Same pixels as MuJoCo's own render with the canvas' field of view set on a model copy
    (the former way, which wrote it into the shared model for each frame)."""
    m, d = scene.model, scene.data
    before = _model_state(m)
    rig = CameraRig(scene, [CameraSpec("L_wide", 160, 120, 0.0, -0.05, 0.0)],
                    np.random.default_rng(0))
    try:
        image = rig.render_ideal("L_wide")
        seg = rig.render_ideal("L_wide", segmentation=True)
        rig.capture(0.0)
        canvas = rig._canvas["L_wide"]
    finally:
        rig.close()
    after = _model_state(m)
    for a, b in zip(before, after, strict=True):
        assert np.array_equal(a, b)

    ref_model = copy.copy(m)
    cid = scene.camera("L_wide")
    ref_model.cam_fovy[cid] = math.degrees(2 * math.atan((canvas.height / 2) / canvas.fy))
    ref_model.vis.global_.offwidth, ref_model.vis.global_.offheight = canvas.width, canvas.height
    with mujoco.Renderer(ref_model, canvas.height, canvas.width) as r:
        option = mujoco.MjvOption()
        option.geomgroup[3] = 0
        r.update_scene(d, cid, option)
        ref = r.render()
        r.enable_segmentation_rendering()
        ref_seg = r.render()
    assert image.shape == ref.shape == (canvas.height, canvas.width, 3)
    assert np.array_equal(image, ref)
    assert np.array_equal(seg, ref_seg)


def test_pixel_noise_leaves_opencvs_generator_alone():
    def opencv_draws():
        out = np.empty(8)
        cv2.randu(out, 0.0, 1.0)
        return out

    cv2.setRNGSeed(7)
    expected = opencv_draws()
    cv2.setRNGSeed(7)
    add_pixel_noise(np.full((60, 80, 3), 128, np.uint8), 3.0, np.random.default_rng(1))
    assert np.array_equal(opencv_draws(), expected)


@pytest.mark.parametrize("std", [0.5, 2.0, 7.5])
def test_noise_table_is_a_rounded_gaussian(std):
    """Each grey level's share of the 65536 table entries is the normal probability of the
    interval that rounds to it (scipy), to the table's resolution."""
    table = noise_table(std)
    values, counts = np.unique(table, return_counts=True)
    p = norm.cdf((values + 0.5) / std) - norm.cdf((values - 0.5) / std)
    assert np.abs(counts / table.size - p).max() <= 2.0 / table.size
    assert values.min() == -values.max() and values.max() == round(4.33 * std)


def test_noise_is_reproducible_and_has_its_std():
    flat = np.full((240, 320, 3), 128, np.uint8)
    a = add_pixel_noise(flat, 4.0, np.random.default_rng(3)).astype(float) - 128
    b = add_pixel_noise(flat, 4.0, np.random.default_rng(3)).astype(float) - 128
    assert np.array_equal(a, b)
    assert a.std() == pytest.approx(math.sqrt(4.0**2 + 1 / 12), rel=0.01)
    assert abs(a.mean()) < 0.03
