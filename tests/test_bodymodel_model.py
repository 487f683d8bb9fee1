"""The body model's state layout, limits (library ValueError, scenario exit-2 line) and parts."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import BaseModel, ConfigDict, ValidationError

from humimic.bodymodel.dimensions import avatar_body, torso_cylinder
from humimic.bodymodel.hand import hand_ellipsoids
from humimic.bodymodel.kinematics import ARM_DOFS, DOF_NAMES, Skeleton
from humimic.bodymodel.limits import JointLimits, JointLimitsConfig
from humimic.bodymodel.model import Cone, Ellipsoid, Part
from humimic.scenario.errors import from_validation_error


def test_limits_reject_inverted_ranges_with_the_dof_named():
    with pytest.raises(ValueError, match=r"R_EB: lower limit 2 must be below the upper limit 1"):
        JointLimits.default(R_EB=(2.0, 1.0))
    with pytest.raises(ValueError, match="unknown DOF"):
        JointLimits.default(R_ELBOW=(0.0, 1.0))
    lim = JointLimits.default()
    q = np.array([[0, 0, 0, 4.0, 0, 0, -2.0, 0, 0, 3.0, 0, 0, 0, 0]])
    assert not lim.inside(q)[0]
    clamped = lim.clamp(q)
    assert lim.inside(clamped)[0]
    assert clamped[0, 3] == pytest.approx(math.pi) and clamped[0, 6] == pytest.approx(-math.pi / 3)


class _Tracker(BaseModel):
    model_config = ConfigDict(extra="forbid")
    joint_limits: JointLimitsConfig = JointLimitsConfig()


def test_limits_config_errors_name_the_key():
    text = "joint_limits:\n  R_EB_deg: [150, 0]\n"
    with pytest.raises(ValidationError) as err:
        _Tracker.model_validate({"joint_limits": {"R_EB_deg": [150, 0]}})
    line = str(from_validation_error(err.value, _Tracker, "s.yaml", text))
    assert line.startswith("s.yaml:2: joint_limits.R_EB_deg: lower limit 150 must be below")
    with pytest.raises(ValidationError) as err:
        _Tracker.model_validate({"joint_limits": {"R_EBB_deg": [0, 90]}})
    line = str(from_validation_error(err.value, _Tracker, "s.yaml"))
    assert "unknown key" in line and "did you mean 'R_EB_deg'" in line
    cfg = _Tracker.model_validate({"joint_limits": {"R_EB_deg": [0, 90], "torso_x_m": [-1, 1]}})
    lim = cfg.joint_limits.to_limits()
    i = DOF_NAMES.index("R_EB")
    assert lim.upper[i] == pytest.approx(math.pi / 2) and lim.lower[0] == -1.0


def test_free_and_fixed_dofs():
    body = avatar_body().with_free(ARM_DOFS["R"] + ARM_DOFS["L"])
    torso = np.array([1.0, 0.2, 1.0, 0.3, 0.0, 0.0])
    q = np.zeros((5, 8))
    q[:, 3] = 1.0
    pose = body.forward(q, fixed=torso)
    assert pose.q.shape == (5, 14)
    np.testing.assert_allclose(pose.q[:, :6], np.broadcast_to(torso, (5, 6)))
    np.testing.assert_allclose(pose.joint("spine"), np.broadcast_to(torso[:3], (5, 3)))
    T = np.eye(4)
    T[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    T[:3, 3] = [0.5, 0, 0]
    moved = pose.to(T)
    np.testing.assert_allclose(moved.joint("r_wrist"), pose.joint("r_wrist") @ T[:3, :3].T
                               + T[:3, 3])
    np.testing.assert_allclose(moved.R[:, 3], T[:3, :3] @ pose.R[:, 3])
    assert body.fixed_names == DOF_NAMES[:6]
    assert body.free_limits.names == ARM_DOFS["R"] + ARM_DOFS["L"]
    with pytest.raises(ValueError, match="free DOFs are 8"):
        body.forward(np.zeros((2, 14)))
    with pytest.raises(ValueError, match="6 fixed values"):
        body.forward(q, fixed=np.zeros(3))
    with pytest.raises(ValueError, match="free DOFs"):
        body.with_free(("R_SFE", "R_ELBOW"))
    assert body.without("abdomen", "thorax", "head").part_names == (
        "r_upper_arm", "r_forearm", "r_hand", "l_upper_arm", "l_forearm", "l_hand")


def test_shapes_validate():
    with pytest.raises(ValueError, match="taper"):
        Cone(0.05, 0.05, 0.3, 0.0)
    with pytest.raises(ValueError, match="semi-axes"):
        Ellipsoid((0.1, 0.0, 0.1))
    with pytest.raises(ValueError, match="unknown segment"):
        Part("x", "r_foot", Ellipsoid((0.1, 0.1, 0.1)))
    with pytest.raises(ValueError, match="upper_arm"):
        Skeleton({"R": np.zeros(3), "L": np.zeros(3)}, np.zeros(3), 0.0, 0.3)
    with pytest.raises(ValueError, match="semi-axes"):
        hand_ellipsoids(np.array([[0, 0, 1, 0, 0, 0, 0.05, 0.0, 0.1]]))


def test_torso_cylinder_of_one_ellipsoid_matches_its_moments():
    """One ellipsoid: its silhouettes are ellipses with z-variance c^2 / 4, so the
    equal-variance height is sqrt(12 c^2 / 4) = sqrt(3) c and the semi-axes are
    area / (2 height) = pi a c / (2 sqrt(3) c) (and b alike)."""
    z0, z1, a, b = torso_cylinder(np.array([0.3]), np.array([[0.1, 0.15, 0.2]]))
    assert (z0 + z1) / 2 == pytest.approx(0.3, abs=1e-3)
    assert z1 - z0 == pytest.approx(math.sqrt(3) * 0.2, rel=0.01)
    assert a == pytest.approx(math.pi * 0.1 / (2 * math.sqrt(3)), rel=0.01)
    assert b == pytest.approx(math.pi * 0.15 / (2 * math.sqrt(3)), rel=0.01)
