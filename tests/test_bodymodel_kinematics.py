"""Forward kinematics and ground-truth angles against MuJoCo: DB's arm at the same angles (the
joint convention maps onto the robot), the avatar's sites for random poses and for the
existing motions (FK of the decomposed shoulder quaternions), scipy's Euler angles."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.bodymodel import avatar as truth
from humimic.bodymodel.dimensions import avatar_body, db_skeleton
from humimic.bodymodel.forward_kernel import segment_frames
from humimic.bodymodel.hand import hand_ellipsoids
from humimic.bodymodel.kinematics import (
    ARM_AXES,
    ARM_JOINTS,
    DOF_NAMES,
    forward_kinematics,
    shoulder_rotation,
    ypr_matrix,
)
from humimic.bodymodel.limits import JointLimits
from humimic.motion import MotionContext, compute_ground_truth, make_motion
from humimic.motion.avatar import QPOS_SLICES, AvatarGeometry, load_avatar_model, zero_qpos
from humimic.motion.config import (
    AxesMotion,
    BVHMotion,
    Figure8Motion,
    HeadSweepMotion,
    PointMotion,
    WalkMotion,
    WaveMotion,
)
from humimic.paths import MODELS_DIR
from humimic.world.scene import build_scene


def _db():
    return mujoco.MjModel.from_xml_path(str(MODELS_DIR / "db_humanoid.xml"))


def test_arm_axes_are_dbs():
    m = _db()
    for side, axes in ARM_AXES.items():
        for joint, (axis, sign) in zip(ARM_JOINTS, axes, strict=True):
            expected = np.zeros(3)
            expected[axis] = sign
            np.testing.assert_array_equal(m.joint(f"{side}_{joint}").axis, expected)


def test_ypr_matches_scipy():
    rng = np.random.default_rng(0)
    ypr = rng.uniform(-3, 3, (50, 3)) * [1, 0.5, 1]
    np.testing.assert_allclose(ypr_matrix(*ypr.T),
                               Rotation.from_euler("ZYX", ypr).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(truth.ypr_from_matrix(ypr_matrix(*ypr.T)), ypr, atol=1e-9)


def _torso_state(R, p):
    return np.concatenate([p, truth.ypr_from_matrix(R)])


@pytest.mark.parametrize("fk", [forward_kinematics, segment_frames], ids=["numpy", "compiled"])
def test_fk_matches_dbs_arms_in_mujoco(fk):
    """DB's arm joints and our FK with DB's skeleton put elbows and wrists at the same places:
    the production (compiled) FK and the numpy reference."""
    m = _db()
    d = mujoco.MjData(m)
    rng = np.random.default_rng(1)
    sk = db_skeleton(m)
    worst = 0.0
    for _ in range(50):
        q = np.zeros(14)
        for name in ("B_TR", "B_TAA", "B_TFE") + tuple(
                f"{s}_{j}" for s in "RL" for j in ARM_JOINTS):
            lo, hi = m.joint(name).range
            d.qpos[m.joint(name).qposadr[0]] = rng.uniform(lo, hi)
        mujoco.mj_kinematics(m, d)
        torso = m.body("torso").id
        q[:6] = _torso_state(d.xmat[torso].reshape(3, 3), d.xpos[torso])
        for k, s in enumerate("RL"):
            q[6 + 4 * k:10 + 4 * k] = [d.qpos[m.joint(f"{s}_{j}").qposadr[0]] for j in ARM_JOINTS]
        R, p = fk(q[None], sk)
        for k, s in enumerate("RL"):
            elbow, wrist = p[0, 3 + 3 * k], p[0, 4 + 3 * k]
            worst = max(worst, np.abs(elbow - d.site(f"{s}_elbow").xpos).max(),
                        np.abs(wrist - d.body(f"{s}_hand").xpos).max())
            np.testing.assert_allclose(R[0, 3 + 3 * k], d.body(f"{s}_forearm").xmat.reshape(3, 3),
                                       atol=1e-9)
    assert worst < 1e-12


def _random_avatar_qpos(rng, n):
    q = zero_qpos(n)
    q[:, 0:3] = rng.normal(0, 0.1, (n, 3))
    for name, spread in (("root_rot", 0.4), ("spine", 0.3), ("r_shoulder", 3.0),
                         ("l_shoulder", 3.0), ("r_wrist", 1.0), ("l_wrist", 1.0)):
        rv = rng.normal(0, spread / 2, (n, 3))
        q[:, QPOS_SLICES[name]] = Rotation.from_rotvec(rv).as_quat(scalar_first=True)
    for s in "rl":
        q[:, QPOS_SLICES[f"{s}_elbow"]] = rng.uniform(0, 2.6, (n, 1))
    return q


def test_decomposed_angles_reproduce_the_avatar_sites():
    m = load_avatar_model()
    d = mujoco.MjData(m)
    g = AvatarGeometry.from_model(m)
    body = avatar_body(m)
    qpos = _random_avatar_qpos(np.random.default_rng(2), 300)
    state = truth.state_from_qpos(qpos, np.eye(4), g)
    pose = body.forward(state)
    worst = 0.0
    for i, q in enumerate(qpos):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        for joint in ("r_shoulder", "r_elbow", "r_wrist", "l_shoulder", "l_elbow", "l_wrist"):
            worst = max(worst, np.abs(pose.joint(joint)[i] - d.site(joint).xpos).max())
    assert worst < 1e-12          # m, rounding only (the issue asks < 1 mm)


def test_angles_round_trip_and_pick_the_branch_inside_the_limits():
    rng = np.random.default_rng(3)
    lim = JointLimits.default()
    for side in "RL":
        # any rotation decomposes into angles that reproduce it
        R = Rotation.random(500, random_state=rng).as_matrix()
        np.testing.assert_allclose(shoulder_rotation(side, *truth.shoulder_angles(R, side).T), R,
                                   atol=1e-9)
        # angles whose other decomposition leaves the limits (|HR| < 80 deg) come back as given
        a = rng.uniform(np.radians([-60, -30, -75]), np.radians([180, 180, 75]), (500, 3))
        a = a[np.abs(np.abs(a[:, 1]) - np.pi / 2) > 0.05]          # away from SAA = +-90 deg
        back = truth.shoulder_angles(shoulder_rotation(side, *a.T), side, lim)
        np.testing.assert_allclose(back, a, atol=1e-9)
    # an arm raised sideways to 120 deg is abduction, not flexion + rotation by 180 deg
    raised = truth.shoulder_angles(shoulder_rotation("R", 0.0, np.radians(120), 0.0), "R")
    np.testing.assert_allclose(raised, [0.0, np.radians(120), 0.0], atol=1e-9)


@pytest.fixture(scope="module")
def scene():
    return build_scene()


MOTIONS = {"wave": WaveMotion(), "point": PointMotion(move=1.0, hold=0.5, rest=0.5),
           "axes": AxesMotion(duration_per_axis=1.0, cycles=1), "figure8": Figure8Motion(),
           "head_sweep": HeadSweepMotion(),
           "walk": WalkMotion(frame="avatar", waypoints=[
               {"t": 0.0, "at": [0.0, 0.0], "heading_deg": 0}, {"t": 3.0, "at": [0.8, 0.3]},
               {"t": 6.0, "at": [0.8, 0.3], "heading_deg": 90}]),
           "bvh": BVHMotion(file=MODELS_DIR.parent / "data/mocap/cmu_01_01.bvh")}


@pytest.mark.parametrize("name", list(MOTIONS))
def test_truth_angles_reproduce_the_motions(scene, name):
    """FK of ``truth_state`` (torso in the robot base frame) puts elbows and wrists on the
    avatar's sites through the existing motions; hands on the hand geoms."""
    duration = 6.0
    ctx = MotionContext.from_scene(scene, duration, np.random.default_rng(0))
    times = np.linspace(0.0, duration, 40)
    gt = compute_ground_truth(scene, make_motion(MOTIONS[name], ctx), times)
    world = SimpleNamespace(gt=gt, scene=scene)
    ticks = np.arange(len(times))
    body = avatar_body(scene.model, "human/")
    pose = body.forward(truth.truth_state(world, ticks, "base"))
    T = gt.T_world_base
    worst = 0.0
    for joint, target in (("r_elbow", "right_elbow"), ("r_wrist", "right_wrist"),
                          ("l_elbow", "left_elbow"), ("l_wrist", "left_wrist")):
        p_world = pose.joint(joint) @ T[:3, :3].T + T[:3, 3]
        worst = max(worst, np.abs(p_world - gt.p_world(target)).max())
    assert worst < 1e-12          # m, rounding only (the issue asks < 1 mm)
    angles = truth.truth_angles(world, ticks)
    np.testing.assert_allclose(angles, truth.truth_state(world, ticks, "world")[:, 6:])
    assert angles.shape == (len(ticks), 8) and truth.truth_torso_pose(world, 3).shape == (6,)
    # Menezes' free hand ellipsoid at the avatar's hand geom (world frame)
    m, d = scene.model, mujoco.MjData(scene.model)
    for side, geom in (("R", "human/r_hand"), ("L", "human/l_hand")):
        R, c, axes = hand_ellipsoids(truth.truth_hand_state(world, ticks, side, "world"))
        for i in (0, len(ticks) // 2, len(ticks) - 1):
            d.qpos[scene.human_qpos] = gt.qpos[i]
            mujoco.mj_kinematics(m, d)
            np.testing.assert_allclose(c[i], d.geom(geom).xpos, atol=1e-9)
            np.testing.assert_allclose(R[i], d.geom(geom).xmat.reshape(3, 3), atol=1e-9)
            np.testing.assert_allclose(axes[i], m.geom(geom).size)


def test_default_limits_hold_the_motions_arms(scene):
    """The default (human) limits contain the arm angles of the scripted motions."""
    ctx = MotionContext.from_scene(scene, 6.0, np.random.default_rng(0))
    lim = JointLimits.default().subset(DOF_NAMES[6:])
    for name in ("wave", "point", "axes", "figure8"):
        gt = compute_ground_truth(scene, make_motion(MOTIONS[name], ctx), np.linspace(0, 6, 30))
        angles = truth.truth_angles(SimpleNamespace(gt=gt, scene=scene), np.arange(30))
        assert lim.inside(angles).all(), name


def test_ypr_from_matrix_is_scipys_zyx_including_gimbal_lock():
    """The closed form (and scipy's own path near gimbal lock) against scipy's ``as_euler``."""
    from scipy.spatial.transform import Rotation

    from humimic.bodymodel.avatar import ypr_from_matrix

    rot = Rotation.random(500, random_state=3)
    R = rot.as_matrix()
    np.testing.assert_allclose(ypr_from_matrix(R), rot.as_euler("ZYX"), atol=1e-12)
    np.testing.assert_allclose(ypr_from_matrix(R[7]), rot[7].as_euler("ZYX"), atol=1e-12)
    locked = ypr_matrix(np.array([0.3]), np.array([np.pi / 2]), np.array([0.2]))[0]
    np.testing.assert_allclose(ypr_matrix(*ypr_from_matrix(locked)[:, None]).reshape(3, 3),
                               locked, atol=1e-9)
