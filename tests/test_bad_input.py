"""Each bad input the review found ending in a traceback (or silently accepted) now exits 2 with
one line on stderr naming what is wrong (issue 10). The property-based version is
``test_input_fuzz.py``."""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np
import pytest

from humimic.motion.bvh import BVHError, load_bvh, parse_bvh
from humimic.paths import MODELS_DIR, SCENARIOS_DIR
from humimic.run import main
from humimic.scenario import dump_scenario, load_scenario
from humimic.sensors.camera_model import corner_radius, max_invertible_radius
from humimic.world.names import EYE_HFOV_DEG, ROBOT_JOINTS
from humimic.world.robot_limits import robot_joint_ranges

GOOD = "name: t\nduration: 0.2\n"


def _cli(tmp_path, capsys, text: str | bytes, *extra: str) -> tuple[int, str]:
    path = tmp_path / "s.yaml"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    code = main([str(path), "--quiet", "--rerun", "off", *extra])
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) <= 1, err
    return code, err


def _bvh_lines(data_dir, n_frames: int = 40) -> list[str]:
    lines = (data_dir / "mocap" / "cmu_01_01.bvh").read_text().splitlines()
    k = lines.index("MOTION")
    return lines[:k + 1] + [f"Frames: {n_frames}", lines[k + 2]] + lines[k + 3:k + 3 + n_frames]


def test_binary_bvh_exits_2(tmp_path, capsys):
    clip = tmp_path / "clip.bvh"
    clip.write_bytes(b"HIERARCHY\nROOT \xff\xfe\x00\x81 {\n")
    with pytest.raises(BVHError, match="clip.bvh line 2: not a text"):
        load_bvh(clip)
    # and through the command line (the clip is read when the world is built)
    code, err = _cli(tmp_path, capsys, GOOD + f"human: {{motion: {{kind: bvh, file: {clip}}}}}\n",
                     "--dry-run")
    assert code == 2 and "clip.bvh line 2: not a text (UTF-8) BVH file" in err


def test_bvh_claiming_a_billion_frames_fails_fast(data_dir):
    lines = _bvh_lines(data_dir)
    k = lines.index("MOTION")
    lines[k + 1] = "Frames: 1000000000"
    with pytest.raises(BVHError, match="expected 1000000000 frame lines .* found 40"):
        parse_bvh("\n".join(lines), "big.bvh")  # no 44.7 GiB allocation first


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "NaN"])
def test_bvh_with_non_finite_values_names_the_line(data_dir, bad):
    lines = _bvh_lines(data_dir)
    k = lines.index("MOTION")
    words = lines[k + 5].split()
    words[3] = bad
    lines[k + 5] = " ".join(words)
    with pytest.raises(BVHError, match=f"line {k + 6}: expected a number in frame 2, got '{bad}'"):
        parse_bvh("\n".join(lines), "nan.bvh")
    offset = next(i for i, line in enumerate(lines) if "OFFSET" in line and i > 5)
    lines[offset] = f"OFFSET 1 {bad} 2"
    with pytest.raises(BVHError, match=f"line {offset + 1}: expected 3 numbers after OFFSET"):
        parse_bvh("\n".join(lines), "nan.bvh")


def test_scenario_with_non_utf8_bytes_exits_2(tmp_path, capsys):
    code, err = _cli(tmp_path, capsys, b"name: t\nduration: 0.2\ndescription: caf\xe9\n")
    assert code == 2
    assert "s.yaml:3: <top level>: not a text file: byte 0xe9 at offset 38 is not UTF-8" in err


def test_head_camera_resolution_is_bounded(tmp_path, capsys):
    code, err = _cli(tmp_path, capsys, GOOD, "--set",
                     "sensors.head_camera.resolution=[100000, 100000]")
    assert code == 2
    assert ("sensors.head_camera.resolution: must be within 16x16 .. 1920x1440 (width x height)"
            " (got [100000, 100000])") in err


def test_section_check_does_not_dump_the_section(tmp_path, capsys):
    """A section-level check (the distortion against the field of view) names the section and
    says the values in its message, without repeating the whole section as the value."""
    code, err = _cli(tmp_path, capsys, GOOD, "--set", "cameras.distortion=[-0.9, 0]")
    assert code == 2 and "cameras: distortion [-0.9, 0] cannot be undistorted" in err
    assert "(got {" not in err


@pytest.mark.parametrize("key", ["cameras.resolution.5", "cameras.resolution.x",
                                 "cameras.resolution.0.y", "cameras..rate"])
def test_set_outside_a_list_exits_2(tmp_path, capsys, key):
    code, err = _cli(tmp_path, capsys, GOOD + "cameras: {resolution: [320, 240]}\n",
                     "--set", f"{key}=10")
    assert code == 2 and "--set" in err and "cameras." in err, err


def test_set_index_names_the_list(tmp_path, capsys):
    code, err = _cli(tmp_path, capsys, GOOD + "cameras: {resolution: [320, 240]}\n",
                     "--set", "cameras.resolution.5=10")
    assert code == 2
    assert "cameras.resolution is a list of 2: no item '5'; allowed: an index 0..1" in err


def test_out_naming_a_file_exits_2(tmp_path, capsys):
    (tmp_path / "taken").write_text("not a directory")
    code, err = _cli(tmp_path, capsys, GOOD, "--out", str(tmp_path / "taken"))
    assert code == 2 and "exists and is not a directory" in err
    code, err = _cli(tmp_path, capsys, GOOD, "--out", str(tmp_path / "taken" / "sub"))
    assert code == 2 and "--out" in err


@pytest.mark.parametrize("section, distortion", [
    ("cameras", "[-50, 0]"), ("cameras", "[-0.2, 0]"), ("cameras", "[0.1, -0.5]"),
    ("sensors.head_camera", "[-0.5, 0]")])
def test_distortion_that_cannot_be_undistorted_exits_2(tmp_path, capsys, section, distortion):
    code, err = _cli(tmp_path, capsys, GOOD, "--set", f"{section}.distortion={distortion}")
    assert code == 2 and "cannot be undistorted" in err and section in err, err


def test_usable_distortions_are_accepted():
    load_scenario(SCENARIOS_DIR / "static.yaml", ["cameras.distortion=[-0.05, 0]"])
    load_scenario(SCENARIOS_DIR / "static.yaml", ["cameras.distortion=[-0.2, 0]",
                                                  "cameras.which=foveal"])
    load_scenario(SCENARIOS_DIR / "sugiyama_fig8.yaml")  # the head camera's [-0.15, 0.02]


@pytest.mark.parametrize("k1, k2", [(-0.05, 0.0), (-0.2, 0.0), (-0.15, 0.02), (0.1, -0.05),
                                    (0.0, -0.01), (0.3, 0.0), (-50.0, 0.0)])
def test_max_invertible_radius_against_a_dense_scan(k1, k2):
    """Where the slope of r (1 + k1 r^2 + k2 r^4) first drops to 1/4, by brute force."""
    r = np.linspace(0.0, 20.0, 2_000_001)
    slope = 1 + 3 * k1 * r**2 + 5 * k2 * r**4
    below = np.flatnonzero(slope < 0.25)
    expected = math.inf if below.size == 0 else r[below[0]] * (1 + k1 * r[below[0]] ** 2
                                                             + k2 * r[below[0]] ** 4)
    assert max_invertible_radius(k1, k2) == pytest.approx(expected, rel=1e-4)


def test_corner_radius_is_the_half_diagonal_over_the_focal_length():
    w, h, hfov = 320, 240, math.radians(EYE_HFOV_DEG["wide"])
    f = (w / 2) / math.tan(hfov / 2)
    assert corner_radius(hfov, w, h) == pytest.approx(math.hypot((w - 1) / 2, (h - 1) / 2) / f)


def test_robot_pose_outside_the_joint_limits_exits_2(tmp_path, capsys):
    code, err = _cli(tmp_path, capsys, GOOD, "--set", "robot.pose.R_EB=3.0")
    assert code == 2
    assert "robot.pose" in err and "R_EB = 3 rad is outside the joint's limits [0, 2.4]" in err
    load_scenario(SCENARIOS_DIR / "static.yaml", ["robot.pose.R_EB=2.4"])  # at the limit: fine


def test_robot_joint_ranges_match_the_compiled_model():
    m = mujoco.MjModel.from_xml_path(str(MODELS_DIR / "db_humanoid.xml"))
    ranges = robot_joint_ranges()
    assert set(ranges) == set(ROBOT_JOINTS)
    for name, (lo, hi) in ranges.items():
        assert tuple(m.joint(name).range) == pytest.approx((lo, hi))


def test_a_bad_duration_is_blamed_on_the_option(tmp_path, capsys):
    code, err = _cli(tmp_path, capsys, GOOD, "--duration", "0")
    assert code == 2 and "s.yaml (--duration): duration: out of range" in err, err
    code, err = _cli(tmp_path, capsys, GOOD, "--seed", "-1")
    assert code == 2 and "(--seed): seed" in err, err


def test_a_bad_set_is_blamed_on_the_option_not_a_file_line(tmp_path, capsys):
    code, err = _cli(tmp_path, capsys, GOOD, "--set", "name.x=1")
    assert code == 2 and "s.yaml (--set): name:" in err and "s.yaml:1" not in err, err


def test_command_line_errors_are_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        _cli(tmp_path, capsys, GOOD, "--duration", "soon")
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--duration: invalid float value: 'soon'" in err


def test_dry_run_builds_and_writes_nothing(tmp_path, capsys):
    code, err = _cli(tmp_path, capsys, GOOD, "--dry-run", "--out", str(tmp_path / "out"))
    assert code == 0 and err == "" and not (tmp_path / "out").exists()


@pytest.mark.parametrize("path", sorted(SCENARIOS_DIR.glob("*.yaml")), ids=lambda p: p.stem)
def test_the_resolved_scenario_a_run_writes_reloads(tmp_path, path):
    scenario = load_scenario(path)
    resolved = tmp_path / "scenario.resolved.yaml"
    resolved.write_text(dump_scenario(scenario))
    again = load_scenario(resolved)
    assert dump_scenario(again) == dump_scenario(scenario)


@pytest.mark.parametrize("frame_time", ["1e-9", "0", "-0.1", "nan", "1e300"])
def test_bvh_frame_time_is_bounded(data_dir, frame_time):
    """A clip is sampled at its frame rate: 1 ns frames would mean billions of samples."""
    lines = _bvh_lines(data_dir)
    k = lines.index("MOTION")
    lines[k + 2] = f"Frame Time: {frame_time}"
    with pytest.raises(BVHError, match=f"line {k + 3}: expected a frame time of 0.0005 to 10 s"):
        parse_bvh("\n".join(lines), "fast.bvh")


def test_a_sweep_setting_past_a_list_names_the_sweep_file(tmp_path, capsys):
    from humimic.sweep.__main__ import main as sweep_main

    path = tmp_path / "sweep.yaml"
    path.write_text(f"scenario: {SCENARIOS_DIR / 'wave.yaml'}\n"
                    "set: {cameras.resolution: [320, 240]}\n"
                    "grid:\n  cameras.resolution.5: [10]\n")
    assert sweep_main([str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "sweep.yaml:4: grid.cameras.resolution.5: cannot be set in the scenario" in err, err


def test_an_error_found_after_the_perception_worker_started_is_one_line(tmp_path, capfd):
    """The blob worker (a child process) starts before the trackers are checked against the
    cameras; when the run stops there, the child must end quietly (it printed a BrokenPipe
    traceback on the same stderr)."""
    code = main([str(SCENARIOS_DIR / "fig12_tbp_pointing.yaml"), "--quiet", "--rerun", "off",
                 "--set", "trackers.tbp.camera=X_wide", "--out", str(tmp_path / "run")])
    time.sleep(0.5)  # the child's last words, if any, come after the parent has given up
    err = capfd.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "trackers.tbp.camera: camera 'X_wide' is not rendered" in err


def test_report_error_prints_one_line_and_returns_2(capsys):
    from humimic.errors import report_error

    assert report_error(ValueError("a\n  b\tc ")) == 2
    assert capsys.readouterr().err == "error: a b c\n"


def test_a_misspelt_sweep_key_gets_a_did_you_mean(tmp_path, capsys):
    from humimic.sweep.__main__ import main as sweep_main

    path = tmp_path / "sweep.yaml"
    path.write_text(f"scenario: {SCENARIOS_DIR / 'wave.yaml'}\nSeedz: 3\n")
    assert sweep_main([str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "sweep.yaml:2: Seedz: unknown key" in err and "did you mean 'seeds'?" in err, err
