"""The compiled limb view (:func:`humimic.bodymodel.limb_view.limb_view`) against
:func:`~humimic.bodymodel.projection.project` and ``BodyView.ellipses_px`` (numpy, tested
against closed forms in ``test_bodymodel_*``): the avatar's models (elliptic cylinders and
truncated cones, ellipsoids, parts rotated on their segments or not), a distorted camera,
parts behind the camera and seen end-on."""

from __future__ import annotations

import numpy as np
import pytest

from humimic import bodymodel as bm
from humimic.bodymodel.kinematics import Skeleton
from humimic.bodymodel.limb_view import limb_view
from humimic.bodymodel.model import BodyModel, Cone, Ellipsoid, Part
from humimic.sensors.camera_model import Intrinsics

#: Camera 2.5 m in front of a person facing it (base x forward, z up).
T_CAM_BASE = np.eye(4)
T_CAM_BASE[:3, :3] = [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]
T_CAM_BASE[:3, 3] = T_CAM_BASE[:3, :3] @ -np.array([-2.5, 0.0, 1.2])


def _aligned_body() -> BodyModel:
    """Parts on their segments without rotation (the kernel's ``aligned`` branch)."""
    sk = Skeleton({"R": np.array([0.0, -0.2, 0.4]), "L": np.array([0.0, 0.2, 0.4])},
                  np.array([0.0, 0.0, 0.5]), 0.3, 0.25)
    parts = (Part("torso", "torso", Cone(0.15, 0.1, 0.5, 1.0)),
             Part("head", "head", Ellipsoid((0.08, 0.1, 0.12)), p_seg_part=np.r_[0, 0, 0.1]),
             Part("r_upper_arm", "r_upper_arm", Cone(0.05, 0.04, 0.3, 0.8)))
    return BodyModel(sk, parts)


@pytest.mark.parametrize("body_kind", ["kpf", "avatar", "aligned"])
@pytest.mark.parametrize("k1", [0.0, -0.2])
def test_limb_view_equals_the_projection(body_kind, k1):
    body = {"kpf": lambda: bm.avatar_body(torso="cylinder"), "avatar": bm.avatar_body,
            "aligned": _aligned_body}[body_kind]()
    intr = Intrinsics(320, 240, 280.0, 285.0, 161.0, 118.0, k1=k1, k2=0.05 if k1 else 0.0)
    rng = np.random.default_rng(3)
    q = np.zeros((200, 14))
    q[:, :3] = (0.0, 0.0, 1.0)
    q[:, 3] = np.pi
    q = q + rng.uniform(-1.0, 1.0, q.shape) * np.r_[[0.3] * 3, [0.8] * 3, [1.5] * 8]
    q[:10, 0] = -3.0                                  # behind the camera
    q[10:20, 0] = -2.45                               # the torso round the camera centre
    q[20, 3:6] = (0.0, -np.pi / 2, 0.0)               # torso axis along the optical axis
    pose = body.forward(body.clamp(q[:, body._free_idx]) if body_kind != "aligned"
                        else q[:, body._free_idx])
    ref = bm.project(body, pose, intr, T_CAM_BASE)
    got = limb_view(body, pose, intr, T_CAM_BASE)
    assert np.array_equal(got.valid, ref.valid) and (~ref.valid).any() and ref.valid.any()
    assert np.array_equal(got.generators, ref.generators)
    assert body_kind == "avatar" or (~ref.generators).any()       # its torso: an ellipsoid
    for a, b in ((got.sides_uv, ref.sides_uv), (got.axis_uv, ref.axis_uv),
                 *zip(got.ellipses_px(), ref.ellipses_px(), strict=True)):
        assert a.shape == b.shape
        assert np.array_equal(np.isnan(a), np.isnan(b))
        fin = np.isfinite(b)
        assert np.allclose(a[fin], b[fin], rtol=1e-9, atol=1e-9)
