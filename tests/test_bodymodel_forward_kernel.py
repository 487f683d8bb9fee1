"""The production forward kinematics (compiled, :mod:`humimic.bodymodel.forward_kernel`,
behind ``BodyModel.forward``) against the numpy reference
:func:`~humimic.bodymodel.kinematics.forward_kinematics` (closed-form y-x-z shoulders; both are
checked against MuJoCo in ``test_bodymodel_kinematics``): every body the code builds -- the
avatar's, the kpf's (elliptic cylinders), TBP's arms-only model with its torso fixed per call,
and DB's skeleton as the joint-mimicry scores use it -- at any angles."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic import bodymodel as bm
from humimic.bodymodel.dimensions import db_skeleton
from humimic.bodymodel.forward_kernel import segment_frames
from humimic.bodymodel.kinematics import DOF_NAMES, forward_kinematics
from humimic.control.joints import arm_points
from humimic.paths import MODELS_DIR
from humimic.perception.trackers.kpf.tracker import kpf_body


def _bodies():
    tbp = bm.avatar_body(torso="cylinder").with_free(bm.ARM_DOFS["R"] + bm.ARM_DOFS["L"])
    return {"avatar": bm.avatar_body(), "kpf": kpf_body(), "tbp": tbp}


@pytest.mark.parametrize("kind", ["avatar", "kpf", "tbp"])
def test_body_forward_equals_the_numpy_reference(kind):
    body = _bodies()[kind]
    rng = np.random.default_rng(6)
    q = rng.uniform(-4.0, 4.0, (100, len(body.free)))
    fixed = rng.uniform(-2.0, 2.0, len(body.fixed_names)) if body.fixed_names else None
    got = body.forward(q, fixed=fixed)
    R, p = forward_kinematics(body.expand(q, fixed), body.skeleton)
    assert np.array_equal(got.q, body.expand(q, fixed))
    assert np.abs(got.R - R).max() < 4e-15          # measured <= 9e-16
    assert np.abs(got.p - p).max() < 4e-15


def test_db_arm_points_equal_the_numpy_reference():
    sk = db_skeleton(mujoco.MjModel.from_xml_path(str(MODELS_DIR / "db_humanoid.xml")))
    angles = np.random.default_rng(7).uniform(-3.0, 3.0, (50, 8))
    q = np.zeros((50, len(DOF_NAMES)))
    q[:, 6:] = angles
    _, p = forward_kinematics(q, sk)
    assert np.abs(arm_points(angles, sk) - p[:, [3, 4, 6, 7]]).max() < 4e-15


def test_rejects_a_wrong_state_shape():
    with pytest.raises(ValueError, match=r"\(N, 14\)"):
        segment_frames(np.zeros((3, 8)), bm.avatar_body().skeleton)
