"""Redundant IK (mink + daqp): same QP as mink.solve_ik, correct frames, limits respected."""

from __future__ import annotations

import mink
import mujoco
import numpy as np
import pytest

from humimic.control.config import IKConfig
from humimic.control.ik import MimicIK, box_bounds, build_robot_model
from humimic.world.names import ROBOT_JOINTS, ROBOT_PREFIX
from humimic.world.scene import SceneOptions, build_scene

DT = 1.0 / 420.0


@pytest.fixture(scope="module")
def model():
    return build_robot_model()


def _ik(model, sites=("R_palm",), **cfg):
    return MimicIK(model, model.key("ready").qpos, list(sites), IKConfig(**cfg), DT)


def test_robot_model_frames_are_the_scenes(model):
    """The IK's robot-only model puts every site where the composed scene does (same q)."""
    scene = build_scene(SceneOptions(interocular=0.09))
    ik_model = build_robot_model(0.09)
    rng = np.random.default_rng(0)
    lo, hi = scene.robot_range.T
    q = rng.uniform(lo, hi)
    d = mujoco.MjData(ik_model)
    d.qpos[:] = q
    mujoco.mj_kinematics(ik_model, d)
    scene.data.qpos[scene.robot_qpos] = q
    mujoco.mj_kinematics(scene.model, scene.data)
    for site in ("R_palm", "L_palm", "R_elbow", "eye_center", "L_eye", "R_eye"):
        np.testing.assert_allclose(d.site(site).xpos, scene.data.site(ROBOT_PREFIX + site).xpos,
                                   atol=1e-12)
    assert tuple(ik_model.joint(i).name for i in range(ik_model.njnt)) == ROBOT_JOINTS


def test_fast_solve_equals_mink_solve_ik(model):
    """Our QP assembly (box bounds, pruned collision rows, daqp directly) gives mink's answer."""
    ik = _ik(model, ("R_palm", "L_palm", "R_elbow"))
    p0 = ik.site_positions().copy()
    rng = np.random.default_rng(3)
    for _ in range(6):
        for task, p in zip(ik.site_tasks, p0 + rng.normal(0, 0.15, p0.shape), strict=True):
            task.set_target(mink.SE3.from_translation(p))
        ours = ik.solve()
        ref = mink.solve_ik(ik.configuration, ik.tasks, DT, "daqp", damping=ik.damping,
                            limits=ik.limits)
        np.testing.assert_allclose(ours, ref, atol=1e-8)
        ik.configuration.integrate_inplace(ours, DT)


def test_box_bounds_are_minks_joint_and_speed_rows(model):
    ik = _ik(model)
    q = ik.q.copy()
    G_c, h_c = ik.limits[0].compute_qp_inequalities(ik.configuration, DT)
    G_v, h_v = ik.limits[1].compute_qp_inequalities(ik.configuration, DT)
    lb, ub = box_bounds(q, ik._lower, ik._upper, ik._gain, ik._vmax, DT)
    n = model.nv
    np.testing.assert_allclose(ub, np.minimum(h_c[:n], h_v[:n]))
    np.testing.assert_allclose(lb, -np.minimum(h_c[n:], h_v[n:]))
    assert np.array_equal(G_c[:n], np.eye(n)) and np.array_equal(G_v[:n], np.eye(n))


def test_reaches_a_target_and_keeps_the_head_still(model):
    ik = _ik(model)
    d = ik.configuration.data
    head0, R0 = d.site("eye_center").xpos.copy(), d.site("eye_center").xmat.reshape(3, 3).copy()
    target = ik.site_positions()[0] + np.array([0.05, 0.15, 0.10])
    for _ in range(420):
        ik.step(target[None])
    # Independent FK: MuJoCo on a fresh MjData at the IK's configuration.
    d2 = mujoco.MjData(model)
    d2.qpos[:] = ik.q
    mujoco.mj_kinematics(model, d2)
    # measured 2026-11-29: palm 3.2e-5 m off, head moved 1.2e-6 m and turned 9.9e-6 deg
    assert np.linalg.norm(d2.site("R_palm").xpos - target) < 1e-4
    assert np.linalg.norm(d2.site("eye_center").xpos - head0) < 4e-6
    R = d2.site("eye_center").xmat.reshape(3, 3)
    assert np.degrees(np.arccos(np.clip((np.trace(R0.T @ R) - 1) / 2, -1, 1))) < 3e-5


def test_speed_limit_on_a_target_jump(model):
    ik = _ik(model, max_joint_speed=3.0)
    target = ik.site_positions()[0] + np.array([0.0, 0.4, 0.3])
    _, v = ik.step(target[None])
    assert np.max(np.abs(v)) <= 3.0 + 1e-9


def test_unreachable_targets_respect_joint_limits(model):
    ik = _ik(model, ("R_palm", "L_palm"))
    rng = np.random.default_rng(5)
    lo = model.jnt_range[:, 0] + ik._lower[0] * 0  # ranges from the model
    hi = model.jnt_range[:, 1]
    lo = model.jnt_range[:, 0]
    for _ in range(300):
        q, v = ik.step(rng.normal([0.5, 0.0, 1.2], 1.5, (2, 3)))
        assert np.all(np.isfinite(q)) and np.all(np.isfinite(v))
        assert np.all(q >= lo) and np.all(q <= hi)
    assert ik.failures == 0


def test_hand_stays_out_of_the_torso(model):
    """A target inside the chest: the collision limit keeps the forearm and hand outside."""
    ik = _ik(model, collision_margin=0.02)
    d = ik.configuration.data
    target = d.geom("thorax").xpos.copy()
    for _ in range(600):
        ik.step(target[None])
    fromto = np.zeros(6)
    for arm in ("R_forearm", "R_hand"):
        for body in ("thorax", "abdomen"):
            dist = mujoco.mj_geomDistance(model, d, model.geom(arm).id, model.geom(body).id,
                                          1.0, fromto)
            assert dist > 0.015, (arm, body, dist)


def test_solve_equals_mink_solve_ik_with_collision_rows_active(model):
    """Pulling both hands into the chest brings arm-body pairs inside the detection distance:
    with those collision rows in the QP, our solve still gives mink's answer."""
    ik = _ik(model, ("R_palm", "L_palm"), collision_margin=0.05)
    target = ik.configuration.data.geom("thorax").xpos.copy()
    rng = np.random.default_rng(8)
    n_rows = []
    for _ in range(60):
        ik.step(np.stack([target, target]) + rng.normal(0, 0.02, (2, 3)))
        ref = mink.solve_ik(ik.configuration, ik.tasks, DT, "daqp", damping=ik.damping,
                            limits=ik.limits)
        np.testing.assert_allclose(ik.solve(), ref, atol=1e-8)
        _, h = ik.collision_limit.compute_qp_inequalities(ik.configuration, DT)
        n_rows.append(int(np.isfinite(h).sum()))
    assert max(n_rows) >= 2


def test_collision_limit_is_minks_in_displacement_units():
    """DisplacementCollisionLimit rewrites one method of mink 1.3's CollisionAvoidanceLimit: for
    this mink release, its rows are mink's (same pairs found, same normal rows) and its bounds
    mink's velocity bounds times dt outside the margin. A new mink fails here first."""
    from importlib.metadata import version

    from humimic.control.ik import MINK_VERSION, DisplacementCollisionLimit

    assert version("mink").startswith(MINK_VERSION + "."), (
        f"mink {version('mink')}: re-check DisplacementCollisionLimit against this release's "
        "CollisionAvoidanceLimit.compute_qp_inequalities, then update MINK_VERSION")
    model = build_robot_model()
    ik = _ik(model, ("R_palm", "L_palm"), collision_margin=0.05)
    target = ik.configuration.data.geom("thorax").xpos.copy()
    kw = dict(geom_pairs=MimicIK.collision_pairs(), gain=0.5,
              minimum_distance_from_collisions=0.05, collision_detection_distance=0.13)
    ours, theirs = DisplacementCollisionLimit(model, **kw), mink.CollisionAvoidanceLimit(model,
                                                                                          **kw)
    rows = 0
    for k in range(40):
        ik.step(np.stack([target, target]) + 0.01 * np.sin(k))
        G, h = ours.compute_qp_inequalities(ik.configuration, DT)
        G_m, h_m = theirs.compute_qp_inequalities(ik.configuration, DT)
        assert np.array_equal(np.isfinite(h), np.isfinite(h_m))
        np.testing.assert_allclose(G, G_m, atol=1e-12)
        outside = np.isfinite(h) & (h > 0)
        np.testing.assert_allclose(h[outside], h_m[outside] * DT, rtol=1e-12)
        rows += int(np.isfinite(h).sum())
    assert rows > 0
