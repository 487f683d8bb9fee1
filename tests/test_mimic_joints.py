"""mimic.mode joints: the angle clamp, and the elbow/wrist points the scores use against
MuJoCo's forward kinematics of DB itself."""

from __future__ import annotations

import mujoco
import numpy as np

from humimic.bodymodel.dimensions import db_skeleton
from humimic.control.joints import ARM_NAMES, arm_points, joint_targets
from humimic.paths import MODELS_DIR


def test_targets_are_clamped_inside_the_ranges():
    lo, hi = np.full(8, -1.0), np.full(8, 2.0)
    q = np.array([-3.0, 0.5, 2.5, 1.99, -0.99, 0.0, 5.0, -5.0])
    np.testing.assert_allclose(joint_targets(q, lo, hi, 0.05),
                               [-0.95, 0.5, 1.95, 1.95, -0.95, 0.0, 1.95, -0.95])


def test_arm_points_match_mujoco_forward_kinematics_of_db():
    m = mujoco.MjModel.from_xml_path(str(MODELS_DIR / "db_humanoid.xml"))
    d = mujoco.MjData(m)
    q = np.array([0.6, 0.4, -0.5, 1.2, 1.5, 0.2, 0.7, 0.3])
    for name, value in zip(ARM_NAMES, q, strict=True):
        d.qpos[m.jnt_qposadr[m.joint(name).id]] = value
    mujoco.mj_forward(m, d)
    R_t, p_t = d.body("torso").xmat.reshape(3, 3), d.body("torso").xpos

    def local(body):
        return R_t.T @ (d.body(body).xpos - p_t)

    got = arm_points(q[None], db_skeleton())[0]
    want = np.stack([local("R_forearm"), local("R_hand"), local("L_forearm"), local("L_hand")])
    np.testing.assert_allclose(got, want, atol=1e-9)
