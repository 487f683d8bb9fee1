"""The kpf's foveal views from both eyes (``trackers.<kpf>.fovea.cameras``,
:class:`~humimic.perception.trackers.kpf.fovea.FovealLikelihood` with several cameras): each
view one more conditionally independent factor, each with its own camera pose."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from _kpf_synth import INTRINSICS, PALETTE, camera, painted_person, scenario_kpf, static_pose

import humimic.bodymodel as bm
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf.config import KpfConfig, KpfFovea
from humimic.perception.trackers.kpf.flips import arm_flips
from humimic.perception.trackers.kpf.fovea import FovealLikelihood
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.sensors.camera_model import Intrinsics

ARM = ("r_upper_arm", "r_forearm", "r_hand")
CFG = KpfConfig(sigma_from_spread=False, colour_gradients=True,
                sigma={"edge": 0.25, "ridge": 0.4, "colour": 0.15, "skin": 0.4})
FOVEA = Intrinsics(320, 240, 753.0, 753.0, 159.5, 119.5)     # the robot's 24 deg eye
BASELINE_M = 0.07


def aimed(c_base: np.ndarray, p_base: np.ndarray) -> np.ndarray:
    """T_cam_base of a camera centred at ``c_base`` whose optical axis passes through
    ``p_base`` (OpenCV axes, image up along the base's +z)."""
    z = (p_base - c_base) / np.linalg.norm(p_base - c_base)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, -R @ c_base
    return T


def eyes():
    """The wide camera (:func:`_kpf_synth.camera`) and two foveal cameras verged on the
    raised right arm's elbow: the left coaxial with the wide one, the right 70 mm to its
    side (the camera's +x); their centres in the base frame and ``T_cam_base``."""
    body, T, q0 = kpf_body(), camera(), static_pose()
    c_left = np.linalg.inv(T)[:3, 3]
    c_right = c_left + np.linalg.inv(T)[:3, 0] * BASELINE_M
    elbow = body.forward(q0[None]).joint("r_elbow")[0]
    return (c_left, aimed(c_left, elbow)), (c_right, aimed(c_right, elbow))


def painted(body, q0, intr, T) -> np.ndarray:
    labels = bm.label_mask(bm.project(body, body.forward(q0[None]), intr, T))
    img = np.full((intr.height, intr.width, 3), 90, np.uint8)
    for p, name in enumerate(body.part_names):
        img[labels == p + 1] = PALETTE.get(name, (128, 128, 128))
    return img


def scene():
    body, T, q0 = kpf_body(), camera(), static_pose()
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    wide = (FrameCues(painted_person(body, q0, T), lut, colour_gradients=True), T)
    fov = [(FrameCues(painted(body, q0, FOVEA, Tf), lut, colour_gradients=True), Tf)
           for _, Tf in eyes()]
    return body, q0, wide, fov


def cv2_project(p_base: np.ndarray, T_cam_base: np.ndarray, intr) -> np.ndarray:
    K = np.array([[intr.fx, 0, intr.cx], [0, intr.fy, intr.cy], [0, 0, 1]], float)
    rvec, _ = cv2.Rodrigues(T_cam_base[:3, :3])
    uv, _ = cv2.projectPoints(p_base.reshape(-1, 1, 3), rvec, T_cam_base[:3, 3], K, None)
    return uv.reshape(-1, 2)


def test_the_stereo_likelihood_is_the_sum_of_the_single_view_ones():
    """Wide view plus both foveal views: the log-likelihood is the wide view's plus, on the
    foveal parts, each foveal view's terms computed by a one-camera :class:`Likelihood`
    with that view's own pose; a view without a frame drops out, the cameras' order does
    not matter."""
    body, q0, (mw, T), fov = scene()
    rng = np.random.default_rng(3)
    q = np.repeat(q0[None], 6, axis=0)
    q[:, 6:10] += rng.normal(0.0, 0.15, (6, 4))
    two = FovealLikelihood(body, INTRINSICS, CFG, [FOVEA, FOVEA], ARM)
    two.adapt({p: c[0] for p, c in two.evaluate(q0[None], mw, T).colours.items()})
    wide, one = Likelihood(body, INTRINSICS, CFG), Likelihood(body, FOVEA, CFG)
    for lik in (wide, one):
        lik.share_references(two.references)
    cols = [body.part_names.index(p) for p in ARM]
    ll_w = wide.evaluate(q, mw, T).log_lik
    ll_v = [one.evaluate(q, m, Tf).terms[:, cols].sum(1) for m, Tf in fov]
    assert np.all(np.abs(ll_v[0] - ll_v[1]) > 1e-6)             # the two views differ
    two.look_views(fov)
    assert np.allclose(two.evaluate(q, mw, T).log_lik, ll_w + ll_v[0] + ll_v[1])
    two.look_views([None, fov[1]])
    assert np.allclose(two.evaluate(q, mw, T).log_lik, ll_w + ll_v[1])
    two.look_views(fov[::-1])
    assert np.allclose(two.evaluate(q, mw, T).log_lik, ll_w + ll_v[0] + ll_v[1])
    two.look_views([None, None])
    assert np.allclose(two.evaluate(q, mw, T).log_lik, ll_w)
    with pytest.raises(ValueError, match="2 cameras"):
        two.look_views(fov[:1])


def test_the_right_eye_projection_is_opencvs():
    """The model's cone axes seen by the right foveal camera (``bm.project`` at its
    ``T_cam_base``, what the likelihood samples) are where ``cv2.projectPoints`` puts the
    axis ends computed from the body's part frames in the base frame."""
    body, q0 = kpf_body(), static_pose()
    (_, _), (_, T_right) = eyes()
    pose = body.forward(q0[None])
    view = bm.project(body, pose, FOVEA, T_right)
    R_ref, p_ref = body.part_frames(pose)
    ci, L = body.layout.cone_idx, body.layout.cone_shape[:, 2]
    ends = np.stack([p_ref[0, ci], p_ref[0, ci] + R_ref[0, ci, :, 2] * L[:, None]], axis=1)
    want = cv2_project(ends.reshape(-1, 3), T_right, FOVEA).reshape(len(ci), 2, 2)
    assert np.allclose(view.axis_uv[0], want, atol=1e-6)


def test_the_right_eye_sees_the_flips_the_left_eye_cannot():
    """The truth's right-arm flips seen from the left eye (arm_flips about its centre) image
    the elbow and wrist on the truth's pixels in the left foveal camera (coaxial: a tie),
    while the right foveal camera, 70 mm to the side, sees each joint moved by the change of
    its disparity, ``f b |1/Z - 1/Z'|`` (closed form; Z the joint's distance from the left
    eye). Measured (cv2 / closed form, px): wrist flip's wrist 5.14 / 5.22, elbow flip's
    elbow 2.91 / 2.93 and wrist 2.25 / 2.29, double flip's wrist 8.96 / 9.09."""
    body, q0 = kpf_body(), static_pose()
    (c_left, T_left), (_, T_right) = eyes()
    flips = arm_flips(body, q0[None], "R", c_left)
    for kind in ("wrist", "elbow", "both"):
        assert np.all(np.isfinite(flips[kind])), kind
        for joint in ("r_elbow", "r_wrist"):
            p = np.stack([body.forward(q[None]).joint(joint)[0] for q in (q0, flips[kind][0])])
            gap = {name: float(np.linalg.norm(np.subtract(*cv2_project(p, Tf, FOVEA))))
                   for name, Tf in (("left", T_left), ("right", T_right))}
            Z = np.linalg.norm(p - c_left, axis=1)
            want = FOVEA.fx * BASELINE_M * abs(1.0 / Z[0] - 1.0 / Z[1])
            assert gap["left"] < 1e-6, (kind, joint, gap)
            assert gap["right"] == pytest.approx(want, rel=0.05, abs=0.05), (kind, joint, gap)
    p = np.stack([body.forward(q[None]).joint("r_wrist")[0] for q in (q0, flips["both"][0])])
    assert np.linalg.norm(np.subtract(*cv2_project(p, T_right, FOVEA))) > 6.0


def test_fovea_cameras_config():
    assert KpfFovea().names == ("L_foveal",)
    assert KpfFovea(camera="R_foveal").names == ("R_foveal",)
    assert KpfFovea(cameras=["L_foveal", "R_foveal"]).names == ("L_foveal", "R_foveal")
    with pytest.raises(ValueError, match="not both"):
        KpfFovea(camera="R_foveal", cameras=["L_foveal"])
    both = KpfFovea(cameras=["L_foveal", "R_foveal"])
    assert KpfFovea(**both.model_dump()) == both           # a run's resolved scenario reloads
    with pytest.raises(ValueError, match="twice"):
        KpfFovea(cameras=["R_foveal", "R_foveal"])


def test_both_foveal_views_separate_the_flips_more_than_the_left_one():
    """On the painted scene, the truth minus each right-arm flip (about the left eye), nats:
    measured wide alone 0.41 / 0.08 / 1.10 (wrist / elbow / double flip), with the left
    foveal view 1.85 / 0.96 / 5.26, with both foveal views 3.72 / 2.38 / 7.71."""
    body, q0, (mw, T), fov = scene()
    (c_left, _), _ = eyes()
    flips = arm_flips(body, q0[None], "R", c_left)
    q = np.concatenate([q0[None], *[flips[k] for k in ("wrist", "elbow", "both")]])
    margin = {}
    for name, views in (("left", [fov[0], None]), ("both", fov)):
        lik = FovealLikelihood(body, INTRINSICS, CFG, [FOVEA, FOVEA], ARM)
        lik.adapt({p: c[0] for p, c in lik.evaluate(q0[None], mw, T).colours.items()})
        lik.look_views(views)
        ll = lik.evaluate(q, mw, T).log_lik
        margin[name] = ll[0] - ll[1:]
    assert np.all(margin["both"] - margin["left"] > 0.5), margin


@pytest.mark.parametrize("cameras, fovea, key, hint", [
    ("{which: both, eyes: left}", "{cameras: [L_foveal, R_foveal]}",
     "trackers.kpf.fovea.cameras.1", "(set cameras.eyes: stereo); did you mean 'L_foveal'?"),
    ("{which: both, eyes: left}", "{camera: R_foveal}", "trackers.kpf.fovea.camera",
     "(set cameras.eyes: stereo)"),
    ("{which: wide, eyes: left}", "{cameras: [R_foveal]}", "trackers.kpf.fovea.cameras.0",
     "(set cameras.which: both, cameras.eyes: stereo)"),
    ("{which: both, eyes: stereo}", "{camera: R_foveal, cameras: [L_foveal]}",
     "trackers.kpf.fovea", "not both"),
])
def test_a_foveal_camera_not_rendered_exits_2_saying_what_to_set(tmp_path, capsys, cameras,
                                                                  fovea, key, hint):
    import textwrap

    from humimic.run import main

    path = tmp_path / "s.yaml"
    path.write_text(textwrap.dedent(f"""\
    name: t
    duration: 0.1
    cameras: {cameras}
    trackers:
      kpf: {{kind: kpf, camera: L_wide, fovea: {fovea}}}
    """))
    code = main([str(path), "--out", str(tmp_path / "out"), "--rerun", "off", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and key in err and hint in err, err


def test_the_stereo_scenario_tracks_with_both_eyes_verged_on_the_arm():
    """``schmidt_table1_stereo`` for 1 s at (150, 2): the kpf's likelihood has both foveal
    views with frames, and the gaze (on the kpf's elbow estimate) has verged both eyes: the
    true elbow projects near each foveal image's centre (measured 2026-11-29 at t = 0.93 s:
    10.6 px in both)."""
    with scenario_kpf("schmidt_table1_stereo.yaml") as (world, kpf):
        lik = kpf.tracker.lik
        assert isinstance(lik, FovealLikelihood) and len(lik.foveas) == 2
        assert all(v is not None for v in lik.views)
        p = world.gt.p_world("right_elbow")[world.gt.index_of(0.93)][None]
        for cam in ("L_foveal", "R_foveal"):
            model = world.eye_rig.camera_model(cam)
            i = model.intrinsics
            off = np.linalg.norm(model.project_world(p)[0] - [i.cx, i.cy])
            assert off < 30.0, (cam, off)
