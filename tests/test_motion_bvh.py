"""BVH parser and forward kinematics: a real CMU clip, a hand-made clip with a closed-form
answer, an independent scipy FK, and line-numbered errors for malformed files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.motion import BVHError
from humimic.motion.bvh import (
    end_site_positions,
    forward_kinematics,
    has_reference_frame,
    load_bvh,
    parse_bvh,
)
from humimic.paths import DATA_DIR

CMU = DATA_DIR / "mocap" / "cmu_01_01.bvh"

SMALL = """HIERARCHY
ROOT root
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT a
  {
    OFFSET 1 0 0
    CHANNELS 3 Xrotation Yrotation Zrotation
    JOINT b
    {
      OFFSET 0 2 0
      CHANNELS 3 Yposition Zrotation Xposition
      End Site
      {
        OFFSET 0 0 3
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.5
0 0 0 0 0 0 0 0 0 0 0 0
1 2 3 90 0 0 0 0 90 1 0 0
"""


def _independent_fk(bvh, frame):
    """Per-frame FK with scipy (intrinsic Euler in channel order), written separately."""
    R, p = {}, {}
    for j, joint in enumerate(bvh.joints):
        vals = bvh.motion[frame, joint.channel_start:joint.channel_start + len(joint.channels)]
        t = joint.offset.copy()
        order, angles = "", []
        for ch, v in zip(joint.channels, vals, strict=True):
            if ch.endswith("position"):
                t["XYZ".index(ch[0])] += v
            else:
                order += ch[0]
                angles.append(v)
        r = Rotation.from_euler(order, angles, degrees=True) if order else Rotation.identity()
        if joint.parent < 0:
            R[j], p[j] = r, t
        else:
            R[j] = R[joint.parent] * r
            p[j] = p[joint.parent] + R[joint.parent].apply(t)
    return np.array([R[j].as_matrix() for j in R]), np.array([p[j] for j in p])


def test_cmu_clip_structure():
    bvh = load_bvh(CMU)
    assert bvh.n_frames == 2752
    assert len(bvh.joints) == 31
    assert bvh.fps == pytest.approx(120.0, rel=1e-4)
    assert bvh.joints[0].name == "Hips" and len(bvh.joints[0].channels) == 6
    assert all(j.channels == ("Zrotation", "Yrotation", "Xrotation") for j in bvh.joints[1:])
    assert bvh.motion.shape == (2752, 6 + 30 * 3)
    assert has_reference_frame(bvh)  # frame 0 is the CMU conversion's reference pose


def test_cmu_fk_matches_independent_scipy_fk():
    bvh = load_bvh(CMU)
    R, p = forward_kinematics(bvh)
    for frame in (0, 1, 500, 2016, 2751):  # 2016: the Hips pass near gimbal lock (Y = -90)
        R_ref, p_ref = _independent_fk(bvh, frame)
        np.testing.assert_allclose(R[frame], R_ref, atol=1e-10)
        np.testing.assert_allclose(p[frame], p_ref, atol=1e-9)


def test_small_clip_closed_form():
    bvh = parse_bvh(SMALL, "small.bvh")
    assert bvh.names == ("root", "a", "b") and bvh.frame_time == 0.5
    R, p = forward_kinematics(bvh)
    # frame 0: rest pose
    np.testing.assert_allclose(p[0], [[0, 0, 0], [1, 0, 0], [1, 2, 0]], atol=1e-12)
    # frame 1: root at (1,2,3) turned 90 deg about z; a turns another 90 about z;
    # b is moved 1 along its y by its position channel.
    np.testing.assert_allclose(p[1, 1], [1, 3, 3], atol=1e-12)
    np.testing.assert_allclose(p[1, 2], [1, 0, 3], atol=1e-12)
    np.testing.assert_allclose(R[1, 2], np.diag([-1.0, -1.0, 1.0]), atol=1e-12)
    ends = end_site_positions(bvh, R, p)
    np.testing.assert_allclose(ends["b"][1], [1, 0, 6], atol=1e-12)


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "clip.bvh"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "old, new, line, expected",
    [
        ("OFFSET 1 0 0", "OFFSET 1 abc 0", 8, "expected 3 numbers after OFFSET, got 'abc'"),
        ("Xrotation Yrotation Zrotation", "Xrot Yrotation Zrotation", 9,
         "expected a channel name"),
        ("CHANNELS 3 Yposition", "CHANNELS three Yposition", 13,
         "expected the number of channels after CHANNELS, got 'three'"),
        ("1 2 3 90 0 0 0 0 90 1 0 0", "1 2 3 90 0 0 0 0 90 1 0", 25,
         "expected 12 channel values in frame 1, got 11"),
        ("1 2 3 90 0 0 0 0 90 1 0 0", "1 2 3 90 0 0 0 x 90 1 0 0", 25,
         "expected a number in frame 1, got 'x'"),
        ("Frames: 2", "Frames: two", 22, "expected a non-negative integer after 'Frames:'"),
        ("Frame Time: 0.5", "Frame Time: -1", 23, "expected a frame time of 0.0005 to 10 s"),
        ("Frames: 2", "Frames: 3", 25, "expected 3 frame lines"),
        ("Frames: 2", "Frames: 1", 25, "more frame lines than 'Frames: 1'"),
        ("MOTION", "MOTIONS", 21, "expected 'MOTION'"),
        ("JOINT a", "JOIN a", 6, "expected 'JOINT', 'End Site' or '}' in root, got 'JOIN'"),
    ],
)
def test_malformed_files_name_file_and_line(tmp_path, old, new, line, expected):
    assert old in SMALL
    path = _write(tmp_path, SMALL.replace(old, new, 1))
    with pytest.raises(BVHError) as err:
        load_bvh(path)
    msg = str(err.value)
    assert msg.startswith(f"clip.bvh line {line}: "), msg
    assert expected in msg, msg


def test_truncated_hierarchy_and_missing_file(tmp_path):
    text = SMALL[: SMALL.index("MOTION")].rstrip().rsplit("}", 1)[0]  # drop the last brace
    expected = r"clip.bvh line 19: unexpected end of file, expected .JOINT., .End Site. or .}."
    with pytest.raises(BVHError, match=expected):
        load_bvh(_write(tmp_path, text))
    with pytest.raises(BVHError, match="nope.bvh: cannot read"):
        load_bvh(tmp_path / "nope.bvh")
