"""A bad scenario prints one line (file, dotted key, value, what is allowed, did-you-mean) on
stderr and exits with status 2 - never a traceback."""

from __future__ import annotations

import difflib
import subprocess
import sys
import textwrap

import pytest

from humimic.run import main

GOOD = """\
name: t
duration: 0.1
human:
  distance: 1.2
  motion: {kind: wave, hand: right, amplitude: 0.25, period: 2.0}
"""


def _run(tmp_path, text: str, *extra: str, capsys) -> tuple[int, str]:
    path = tmp_path / "s.yaml"
    path.write_text(textwrap.dedent(text))
    code = main([str(path), "--out", str(tmp_path / "out"), "--rerun", "off", "--quiet", *extra])
    err = capsys.readouterr().err.strip()
    return code, err


@pytest.mark.parametrize("text, must_contain", [
    (GOOD.replace("duration", "duraton"),
     ["s.yaml:2", "duraton", "unknown key", "did you mean 'duration'"]),
    (GOOD.replace("distance: 1.2", "distnce: 1.2"),
     ["s.yaml:4", "human.distnce", "allowed:", "distance", "did you mean 'distance'"]),
    (GOOD.replace("distance: 1.2", "distance: far"), ["human.distance", "'far'"]),
    (GOOD.replace("distance: 1.2", "distance: -1"), ["human.distance", "out of range", "> 0.3"]),
    (GOOD.replace("kind: wave", "kind: wav"),
     ["human.motion.kind", "'wav'", "did you mean 'wave'"]),
    (GOOD.replace("hand: right", "hand: rihgt"),
     ["human.motion.hand", "'rihgt'", "did you mean 'right'"]),
    (GOOD.replace("amplitude: 0.25", "amplitud: 0.25"),
     ["human.motion.amplitud", "did you mean 'amplitude'"]),
    (GOOD + "cameras: {resolution: [320, 240], rate: -5}\n", ["cameras.rate", "out of range"]),
    (GOOD + "cameras: {which: fovea}\n", ["cameras.which", "did you mean 'foveal'"]),
    (GOOD + "trackers: {k: {kind: kpf, d_arm: [1, 2]}}\n",
     ["trackers.k.d_arm", "unknown key", "did you mean 'D_arm_deg'"]),
    (GOOD.replace("motion: {kind: wave, hand: right, amplitude: 0.25, period: 2.0}",
                  "motion: {kind: bvh, file: no_such_clip.bvh}"),
     ["human.motion.file", "file not found", "no_such_clip.bvh"]),
    (GOOD + "slam: {noise: {sigma_accel: -1}}\n",  # a number-or-'sensor' union
     ["slam.noise.sigma_accel: out of range", "> 0.0"]),
    (GOOD + "mimic: {gaze: {target: rigt_hand}}\n",  # a name checked by a validator
     ["s.yaml:6", "mimic.gaze.target", "'rigt_hand'", "did you mean 'right_hand'"]),
    (GOOD + "cameras: {which: wide, eyes: left}\ntrackers:\n  h: {kind: hand2d, camera: L_wid}\n",
     ["s.yaml:8: trackers.h.camera", "not rendered", "did you mean 'L_wide'"]),  # a build check
    (GOOD + "trackers: {kpf: {kind: kpf}}\nmimic: {gaze: {enabled: true, tracker: kfp}}\n",
     ["s.yaml:7: mimic.gaze.tracker", "no such tracker", "did you mean 'kpf'"]),
    ("name: t\nhuman: [1, 2]\n", ["human"]),
    ("name: [unclosed\n", ["not valid YAML"]),
])
def test_bad_scenario_exits_2_with_one_line(tmp_path, capsys, text, must_contain):
    code, err = _run(tmp_path, text, capsys=capsys)
    assert code == 2
    assert len(err.splitlines()) == 1, err
    for piece in must_contain:
        assert piece in err, f"{piece!r} not in {err!r}"


def test_bad_override_names_the_key(tmp_path, capsys):
    code, err = _run(tmp_path, GOOD, "--set", "human.distanse=2", capsys=capsys)
    assert code == 2 and "human.distanse" in err and "did you mean 'distance'" in err


def test_a_build_check_names_the_option_that_set_the_key(tmp_path, capsys):
    code, err = _run(tmp_path, GOOD + "cameras: {which: wide, eyes: left}\n", "--set",
                     "trackers={h: {kind: hand2d, camera: R_wide}}", capsys=capsys)
    assert code == 2 and "s.yaml (--set): trackers.h.camera" in err, err


def test_unknown_name_suggests_what_difflib_finds_closest():
    from humimic.errors import unknown_name
    from humimic.world.names import HUMAN_TARGETS

    for typo in ("rigt_hand", "LEFT_ELBOW", "pelvs", "zzz"):
        message = str(unknown_name("human target", typo, HUMAN_TARGETS))
        close = difflib.get_close_matches(typo.lower(), HUMAN_TARGETS, n=1, cutoff=0.5)
        assert message.startswith(f"unknown human target {typo!r}; allowed: head, ")
        assert message.endswith(f"; did you mean '{close[0]}'?" if close else "headcam")


def test_missing_scenario_file(tmp_path, capsys):
    code = main([str(tmp_path / "nope.yaml"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "not found" in err and len(err.strip().splitlines()) == 1


def test_malformed_bvh_names_the_line(tmp_path, capsys, data_dir):
    lines = (data_dir / "mocap" / "cmu_01_01.bvh").read_text().splitlines()
    bad_line = next(i for i, line in enumerate(lines) if "OFFSET" in line and i > 10)
    lines[bad_line] = "    OFFSET 1.0 abc 2.0"
    clip = tmp_path / "bad.bvh"
    clip.write_text("\n".join(lines[:400]) + "\n")
    text = GOOD.replace("motion: {kind: wave, hand: right, amplitude: 0.25, period: 2.0}",
                        f"motion: {{kind: bvh, file: {clip}}}")
    code, err = _run(tmp_path, text, capsys=capsys)
    assert code == 2 and "bad.bvh" in err and f"line {bad_line + 1}" in err, err
    assert len(err.splitlines()) == 1


def test_cli_prints_no_traceback(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD.replace("kind: wave", "kind: wav"))
    proc = subprocess.run([sys.executable, "-m", "humimic.run", str(path), "--quiet"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
