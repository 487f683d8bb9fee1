"""BVH retargeting: MuJoCo FK of the retargeted avatar vs the BVH's own FK of the real CMU clip
(through the similarity transform the retargeting declares), feet, timing and heading."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic.errors import InputError
from humimic.motion import BVHError, MotionContext, make_motion
from humimic.motion.avatar import AvatarGeometry, load_avatar_model
from humimic.motion.bvh import (
    drop_first_frames,
    end_site_positions,
    forward_kinematics,
    load_bvh,
)
from humimic.motion.config import BVHMotion
from humimic.motion.playback import BVHPlayback
from humimic.motion.retarget import M_AVATAR_BVH, retarget
from humimic.paths import DATA_DIR

CMU = DATA_DIR / "mocap" / "cmu_01_01.bvh"
SITES = {"r_shoulder": "RightArm", "r_elbow": "RightForeArm", "r_wrist": "RightHand",
         "l_shoulder": "LeftArm", "l_elbow": "LeftForeArm", "l_wrist": "LeftHand"}


@pytest.fixture(scope="module")
def setup():
    m = load_avatar_model()
    g = AvatarGeometry.from_model(m)
    bvh = drop_first_frames(load_bvh(CMU), 1)  # frame 0 is a reference pose
    clip = retarget(bvh, g, smoothing_hz=None)
    frames = np.arange(0, bvh.n_frames, 8)
    d = mujoco.MjData(m)
    sites = {k: [] for k in [*SITES, "head", "pelvis"]}
    R_body = {k: [] for k in ("pelvis", "head")}
    lowest = []
    for f in frames:
        d.qpos[:] = clip.qpos[f]
        mujoco.mj_kinematics(m, d)
        for k in sites:
            sites[k].append(d.site(k).xpos.copy())
        for k in R_body:
            R_body[k].append(d.body(k).xmat.reshape(3, 3).copy())
        corners = []
        for foot in ("r_foot", "l_foot"):
            gid = m.geom(foot).id
            R, c, size = d.geom_xmat[gid].reshape(3, 3), d.geom_xpos[gid], m.geom_size[gid]
            corners += [c + R @ (size * np.array([x, y, -1.0])) for x in (-1, 1) for y in (-1, 1)]
        lowest.append(min(p[2] for p in corners))
    # The BVH's own FK, mapped by the declared transform p = R_yaw (scale M p_bvh) + offset.
    R_b, p_b = forward_kinematics(bvh)
    A = clip.R_yaw @ M_AVATAR_BVH

    def to_avatar(p):
        return clip.scale * p @ A.T + clip.offset

    ref = {k: to_avatar(p_b[frames, bvh.index(j)]) for k, j in SITES.items()}
    head_top = end_site_positions(bvh, R_b, p_b)["Head"][frames]
    ref["head"] = to_avatar(0.5 * (p_b[frames, bvh.index("Head")] + head_top))  # head centre
    ref["pelvis"] = to_avatar(0.5 * (p_b[frames, bvh.index("RightUpLeg")]
                                     + p_b[frames, bvh.index("LeftUpLeg")]))
    # segment orientation = R_yaw M R_bvh M^T (torso and head have no rest offset)
    R_ref = {k: A @ R_b[frames, bvh.index(j)] @ M_AVATAR_BVH.T
             for k, j in (("pelvis", "Hips"), ("head", "Head"))}
    return dict(g=g, bvh=bvh, clip=clip, frames=frames, lowest=np.array(lowest),
                sites={k: np.array(v) for k, v in sites.items()}, ref=ref,
                R_body={k: np.array(v) for k, v in R_body.items()}, R_ref=R_ref, p_b=p_b)


def _angle_deg(a, b):
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


def _rot_angle_deg(Ra, Rb):
    c = (np.einsum("nij,nij->n", Ra, Rb) - 1.0) / 2.0
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def test_root_scale_matches_the_standing_subject(setup):
    """Independent estimate: the avatar's hip height over the BVH's hip-line height above its
    lowest foot point while the subject stands in the first 0.5 s."""
    bvh, g, p_b = setup["bvh"], setup["g"], setup["p_b"]
    first = slice(0, 60)
    hip_y = 0.5 * (p_b[first, bvh.index("RightUpLeg"), 1] + p_b[first, bvh.index("LeftUpLeg"), 1])
    foot = [bvh.index(n) for n in ("RightFoot", "RightToeBase", "LeftFoot", "LeftToeBase")]
    floor_y = np.min(p_b[first][:, foot, 1], axis=1)
    estimate = g.pelvis[2] / np.mean(hip_y - floor_y)
    assert setup["clip"].scale == pytest.approx(estimate, rel=0.03)
    # with the height-based scale the subject would be the avatar's height within 10 %
    assert g.height / (setup["clip"].scale * 26.5) == pytest.approx(1.07, abs=0.04)  # 1.086


def test_segment_directions_and_orientations_track_the_bvh(setup):
    s, r = setup["sites"], setup["ref"]
    for side in "rl":
        upper = _angle_deg(s[f"{side}_elbow"] - s[f"{side}_shoulder"],
                           r[f"{side}_elbow"] - r[f"{side}_shoulder"])
        fore = _angle_deg(s[f"{side}_wrist"] - s[f"{side}_elbow"],
                          r[f"{side}_wrist"] - r[f"{side}_elbow"])
        # measured 2026-11-29: upper arm 1.2e-6 deg (exact up to the solver's rounding),
        # forearm 1.37 deg
        assert upper.max() < 4e-6, upper.max()
        assert fore.max() < 3.0, fore.max()
    for k in ("pelvis", "head"):
        err = _rot_angle_deg(setup["R_body"][k], setup["R_ref"][k])
        assert err.max() < 1e-5, (k, err.max())  # measured 2.4e-6 (pelvis), 3.6e-6 deg (head)
    # the root follows the BVH hip line exactly
    np.testing.assert_allclose(s["pelvis"], r["pelvis"], atol=1e-9)


def test_positions_within_a_few_centimetres(setup):
    """Elbows and wrists relative to their shoulder, the head relative to the shoulders'
    midpoint: the segment lengths differ (upper arm / forearm: avatar 0.326 / 0.256 m, the
    scaled BVH 0.31-0.32 / 0.21 m), so a few cm, not zero."""
    s, r = setup["sites"], setup["ref"]
    for side in "rl":
        for joint in ("elbow", "wrist"):
            e = np.linalg.norm((s[f"{side}_{joint}"] - s[f"{side}_shoulder"])
                               - (r[f"{side}_{joint}"] - r[f"{side}_shoulder"]), axis=1)
            assert e.max() < 0.08, (side, joint, e.max())
    mid_s = 0.5 * (s["r_shoulder"] + s["l_shoulder"])
    mid_r = 0.5 * (r["r_shoulder"] + r["l_shoulder"])
    e = np.linalg.norm((s["head"] - mid_s) - (r["head"] - mid_r), axis=1)
    assert np.median(e) < 0.04 and np.percentile(e, 95) < 0.08, (np.median(e), e.max())


def test_feet_stand_on_the_floor(setup):
    lowest, frames = setup["lowest"], setup["frames"]
    standing = lowest[frames < 120]  # the subject stands still in the first second
    assert np.all((standing > -0.005) & (standing < 0.03)), standing
    assert abs(np.percentile(lowest, 5)) < 0.01
    assert np.percentile(lowest, 1) > -0.05  # rigid feet dip only briefly (toe-down poses)


def test_faces_the_robot_at_the_start(setup):
    fwd = setup["R_body"]["pelvis"][0][:, 0]
    assert np.degrees(np.arctan2(fwd[1], fwd[0])) == pytest.approx(0.0, abs=1e-9)  # 1.7e-15


def test_playback_start_speed_duration(setup):
    clip, g = setup["clip"], setup["g"]
    dt = clip.frame_time
    start = 120 * dt  # on a frame
    play = BVHPlayback(clip, g, start=start, speed=2.0, duration=360 * dt)
    assert play.sample_rate == pytest.approx(2.0 / dt)
    k = np.arange(0, 700)
    np.testing.assert_allclose(play.sample(k * dt / 2.0), clip.qpos[120 + k], atol=1e-9)
    end = 120 + 720  # start + speed * duration
    np.testing.assert_allclose(play.sample(np.array([5.0]))[0], clip.qpos[end], atol=1e-9)
    assert play.duration == pytest.approx(360 * dt)
    # between frames: a blend of the neighbours
    mid = play.sample(np.array([dt / 4.0]))[0]
    np.testing.assert_allclose(mid[:3], 0.5 * (clip.qpos[120, :3] + clip.qpos[121, :3]),
                               atol=1e-12)


def test_bvh_config_end_to_end(tmp_path):
    ctx = MotionContext.facing_robot(duration=2.0)
    motion = make_motion(BVHMotion(file=CMU, start=5.0, speed=0.5), ctx)
    q = motion.sample(np.linspace(0, 2, 5))
    assert q.shape == (5, 51) and np.all(np.isfinite(q))
    assert all(k.startswith("range_") for k in motion.diagnostics(np.linspace(0, 2, 50)))
    with pytest.raises(InputError, match=r"cmu_01_01.bvh: start 100.0 s is after the clip's end"):
        make_motion(BVHMotion(file=CMU, start=100.0), ctx)
    bad = tmp_path / "bad.bvh"
    bad.write_text(CMU.read_text().replace("OFFSET 2.44811", "OFFSET x2.44811", 1))
    with pytest.raises(BVHError, match=r"bad.bvh line 16: expected 3 numbers after OFFSET"):
        make_motion(BVHMotion(file=bad), ctx)


def test_non_cmu_skeleton_and_bad_joint_map(tmp_path):
    from pydantic import ValidationError

    clip = tmp_path / "other.bvh"
    clip.write_text(CMU.read_text().replace("RightForeArm", "R_Elbow"))
    ctx = MotionContext.facing_robot()
    with pytest.raises(BVHError, match=r"other.bvh: no joint 'RightForeArm' \(joints: Hips,"):
        make_motion(BVHMotion(file=clip), ctx)
    q = make_motion(BVHMotion(file=clip, joint_map={"r_forearm": "R_Elbow"}), ctx).sample(
        np.array([1.0]))
    assert np.all(np.isfinite(q))
    with pytest.raises(ValidationError, match="unknown avatar segment 'r_elbow'"):
        BVHMotion(file=clip, joint_map={"r_elbow": "R_Elbow"})
