"""Robot commands (Sugiyama sec. V-C): targets and thresholds against closed forms, the gate's
"previous finished" rule, the follower's minimum-jerk moves, the whole loop in the room (the
robot's base, head and hand follow the wearer), and scenarios that cannot run (exit 2)."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.control import commands as cmds
from humimic.control.follow import Segment
from humimic.paths import SCENARIOS_DIR
from humimic.run import main, run_one
from humimic.scenario import load_scenario


def test_movement_target_is_the_displacement_in_R():
    start = np.array([0.0, 0.14, -2.5])  # W: x left, y up, z forward
    np.testing.assert_allclose(cmds.movement_target(start + [1.25, 0.02, 0.0], start),
                               [0.0, 1.25])  # a step to the left: y_R
    np.testing.assert_allclose(cmds.movement_target(start + [0.0, 0.0, 0.7], start),
                               [0.7, 0.0])  # forward: x_R


def test_head_angles_are_pan_left_and_tilt_down():
    for pan, tilt in ((0.3, 0.0), (-0.5, 0.25), (0.0, -0.2)):
        # the camera turned left about W's up (y), then pitched down about its own x (left)
        R = Rotation.from_euler("y", pan) * Rotation.from_euler("x", tilt)
        np.testing.assert_allclose(cmds.head_angles(R.as_matrix()), [pan, tilt], atol=1e-12)


def test_arm_target_maps_the_remote_from_the_eyes():
    eyes = np.array([0.1, 0.0, 1.6])
    # level head: the remote 0.5 ahead, 0.2 right, 0.25 below the camera
    p_I = np.array([-0.2, -0.25, 0.5])
    np.testing.assert_allclose(cmds.arm_target(p_I, np.eye(3), eyes), eyes + [0.5, -0.2, -0.25])
    # the head pitched down: the same remote in I maps lower and nearer (R_W_I p_I)
    R = Rotation.from_euler("x", 0.3).as_matrix()
    got = cmds.arm_target(p_I, R, eyes)
    np.testing.assert_allclose(np.linalg.norm(got - eyes), np.linalg.norm(p_I))
    assert got[2] < eyes[2] - 0.25 and got[0] < eyes[0] + 0.5


@pytest.mark.parametrize("kind, last, target, expect", [
    ("move", [0, 0], [0.49, 0.99], False),
    ("move", [0, 0], [0.51, 0.0], True),  # longitudinal 0.5 m
    ("move", [0, 0], [0.0, -1.01], True),  # lateral 1.0 m
    ("head", [0, 0], np.radians([3.0, 1.9]), False),
    ("head", [0, 0], np.radians([3.0, -2.1]), True),  # |pan| + |tilt| > 5 deg
    ("arm", [0, 0, 0], [0.03, 0.03, 0.02], False),
    ("arm", [0, 0, 0], [0.03, 0.03, 0.03], True),  # 5.2 cm > 5 cm
])
def test_thresholds_are_the_papers(kind, last, target, expect):
    assert cmds.exceeds(kind, np.array(target, float), np.array(last, float),
                        cmds.Thresholds()) is expect


def test_a_command_waits_for_the_previous_one_of_its_kind():
    gate = cmds.CommandGate()
    gate.start("move", np.zeros(2))
    gate.start("arm", np.zeros(3))
    assert gate.offer("move", np.array([0.6, 0.0]))
    assert not gate.offer("move", np.array([1.5, 0.0]))  # busy
    assert gate.offer("arm", np.array([0.1, 0.0, 0.0]))  # another kind: independent
    gate.done("move")
    assert not gate.offer("move", np.array([0.9, 0.0]))  # 0.3 m from the last: below
    assert gate.offer("move", np.array([1.2, 0.0]))


def test_segment_is_minimum_jerk_at_the_peak_speed():
    seg = Segment.to([0.0, 0.0], [0.3, 0.4], 1.0, peak_speed=0.5, min_duration=0.1)
    assert seg.duration == pytest.approx(1.875 * 0.5 / 0.5)
    np.testing.assert_allclose(seg.at(0.5), [0, 0])
    np.testing.assert_allclose(seg.at(1.0 + seg.duration / 2), [0.15, 0.2])
    np.testing.assert_allclose(seg.at(9.0), [0.3, 0.4])
    dt = 1e-4
    mid = 1.0 + seg.duration / 2
    speed = np.linalg.norm(seg.at(mid + dt) - seg.at(mid - dt)) / (2 * dt)
    assert speed == pytest.approx(0.5, rel=1e-4)


@pytest.mark.slow
def test_the_robot_follows_a_step_to_the_left(tmp_path):
    """Fig. 10's first 9.5 s: the wearer steps 1.25 m left and back right; ground-truth head,
    the arm EKF's remote."""
    scenario = load_scenario(SCENARIOS_DIR / "sugiyama_fig10_robot_control.yaml", duration=9.5,
                             overrides=["slam=null", "arm.head_pose=oracle",
                                        "commands.head_pose=oracle"])
    m = run_one(scenario, tmp_path, rerun="off", progress=False)
    c = m["commands"]
    assert c["count"]["move"] == 2  # left once 1.0 m lateral, right once back past it
    assert c["move"]["finished"] == 1
    assert 2.5 < c["move"]["execution_s_mean"] < 6.0  # measured 4.1 s (1 m at <= 0.4 m/s)
    assert 1.0 < c["move"]["path_lag_s"] < 4.0  # measured 2.4 s
    assert c["count"]["head"] == 1  # tilt 18 deg down at the start, then still
    assert c["head"]["angle_error_after_deg_mean"] < 1.0  # measured 0.47, 0.33 deg (11-29)
    assert c["arm"]["finished"] >= 1
    assert c["arm"]["palm_error_after_m_mean"] < 0.07  # measured 0.023, 0.028 m (11-29)
    assert m["arm"]["depth_rmse_m"] < 0.007  # measured 0.0029, 0.0024 m (11-29)
    assert (tmp_path / "commands.png").is_file()


def _write(tmp_path, body: str):
    path = tmp_path / "s.yaml"
    path.write_text(textwrap.dedent("""\
    name: t
    duration: 0.1
    room: sugiyama
    human: {wiimote: true}
    cameras: {enabled: false}
    sensors: {head_camera: {enabled: true}}
    """) + textwrap.dedent(body))
    return path


@pytest.mark.parametrize("body, key", [
    ("commands: {head_pose: oracle, arm_pose: oracle}\n", "robot.base"),
    ("robot: {base: planar}\ncommands: {head_pose: oracle}\n", "commands.arm_pose"),
    ("robot: {base: planar}\ncommands: {arm_pose: oracle}\n", "commands.head_pose"),
    ("robot: {base: planar}\ncommands: {head_pose: oracle, arm_pose: oracle}\nmimic: {}\n",
     "commands"),
])
def test_commands_that_cannot_run_exit_2_naming_the_key(tmp_path, capsys, body, key):
    code = main([str(_write(tmp_path, body)), "--out", str(tmp_path / "out"), "--rerun", "off",
                 "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and key in err, err
