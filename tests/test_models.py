"""Every model and composed scene compiles and steps for 1 s without a MuJoCo warning
(as mujoco_menagerie's model tests do)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic.paths import MODELS_DIR
from humimic.world.names import ROBOT_JOINTS
from humimic.world.scene import SceneOptions, build_scene

MODEL_FILES = sorted(p.name for p in MODELS_DIR.glob("*.xml"))


def _step_without_warnings(model: mujoco.MjModel, data: mujoco.MjData, seconds: float = 1.0):
    n = int(round(seconds / model.opt.timestep))
    for _ in range(n):
        mujoco.mj_step(model, data)
    warnings = {mujoco.mjtWarning(i).name: w.number for i, w in enumerate(data.warning)
                if w.number}
    assert not warnings, f"MuJoCo warnings: {warnings}"
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))


@pytest.mark.parametrize("name", MODEL_FILES)
def test_model_file_steps_without_warnings(name):
    model = mujoco.MjModel.from_xml_path(str(MODELS_DIR / name))
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    _step_without_warnings(model, data)


@pytest.mark.parametrize("opts", [
    SceneOptions(),
    SceneOptions(distance=0.8, lateral=0.3, interocular=0.09, eye_resolution=(640, 480)),
    SceneOptions(distance=2.5, eye_resolution=(640, 360), shadows=True, msaa=True,
                 show_wiimote=True, skin=(0.45, 0.3, 0.22)),
    SceneOptions(room="sugiyama", base="planar", show_wiimote=True),
], ids=["default", "near-wide-eyes", "far-16x9-shadows", "wearable-room-planar-base"])
def test_scene_steps_without_warnings(opts):
    scene = build_scene(opts)
    _step_without_warnings(scene.model, scene.data)


def test_robot_has_db_joints_and_mass():
    model = mujoco.MjModel.from_xml_path(str(MODELS_DIR / "db_humanoid.xml"))
    names = tuple(model.joint(i).name for i in range(model.njnt))
    assert names == ROBOT_JOINTS and model.nu == 30
    assert 79.0 < mujoco.mj_getTotalmass(model) < 81.0
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    top = max(data.geom_xpos[g][2] + model.geom_rbound[g] for g in range(model.ngeom))
    assert 1.80 < top < 1.92  # about 1.85 m tall
    assert model.opt.timestep > 0


def test_robot_cameras_have_the_papers_fields_of_view():
    scene = build_scene(SceneOptions(eye_resolution=(320, 240)))
    m = scene.model
    for name, hfov in (("L_wide", 100.0), ("R_wide", 100.0), ("L_foveal", 24.0),
                       ("R_foveal", 24.0)):
        fovy = np.radians(m.cam_fovy[scene.camera(name)])
        got = np.degrees(2 * np.arctan(np.tan(fovy / 2) * 320 / 240))
        assert got == pytest.approx(hfov, abs=1e-6)
    eyes = [scene.data.site(scene.robot_site(s)).xpos for s in ("L_eye", "R_eye")]
    assert np.linalg.norm(eyes[0] - eyes[1]) == pytest.approx(0.07, abs=1e-9)


def test_scene_physics_runs_at_840hz_with_implicitfast():
    scene = build_scene()
    assert scene.model.opt.timestep == pytest.approx(1 / 840)
    assert scene.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


def test_person_stands_at_the_requested_distance_facing_the_robot():
    scene = build_scene(SceneOptions(distance=1.7, lateral=0.2))
    d = scene.data
    d.qpos[scene.robot_qpos] = 0.0  # distance is defined with the robot in its zero pose
    mujoco.mj_forward(scene.model, d)
    eye = d.site(scene.robot_site("eye_center")).xpos
    head = d.site(scene.human_site("head")).xpos
    assert np.hypot(*(head - eye)[:2]) == pytest.approx(np.hypot(1.7, 0.2), abs=1e-6)
    # The person faces the robot: their avatar x axis points to world -x.
    assert scene.T_world_avatar[:3, 0] @ np.array([-1.0, 0, 0]) == pytest.approx(1.0)
