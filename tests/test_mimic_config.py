"""Bad mimic input: one line on stderr naming the key, exit status 2."""

from __future__ import annotations

import textwrap

import pytest

from humimic.control.config import DRIVABLE_SITES, MimicConfig
from humimic.run import main

BASE = """\
name: t
duration: 0.2
output: {rerun: "off", plots: false}
human:
  distance: 1.2
  motion: {kind: wave, hand: right, amplitude: 0.25, period: 2.0}
mimic:
"""


def _run(tmp_path, capsys, mimic: str) -> tuple[int, str]:
    path = tmp_path / "s.yaml"
    path.write_text(BASE + textwrap.indent(textwrap.dedent(mimic), "  "))
    code = main([str(path), "--out", str(tmp_path / "out"), "--quiet"])
    return code, capsys.readouterr().err.strip()


@pytest.mark.parametrize("mimic, must_contain", [
    ("map: {right_hnd: R_palm}\n",
     ["mimic.map", "unknown human target 'right_hnd'", "right_hand", "left_hand", "head"]),
    ("map: {right_hand: R_plam}\n",
     ["mimic.map", "unknown robot site 'R_plam'", *DRIVABLE_SITES]),
    ("map: {right_hand: L_eye}\n", ["mimic.map", "'L_eye' cannot be driven", "eye", "R_palm"]),
    ("map: {head: eye_center}\n", ["mimic.map", "'eye_center' cannot be driven"]),
    ("map: {right_hand: R_palm, left_hand: R_palm}\n", ["mimic.map", "'R_palm'", "both"]),
    ("map: {}\n", ["mimic.map", "empty"]),
    ("scale: 0\n", ["mimic.scale", "out of range", "> 0"]),
    ("scale: -1.5\n", ["mimic.scale", "out of range"]),
    ("scale: automatic\n", ["mimic.scale", "not a scale", "auto"]),
    ("fit: {time_constant: -1}\n", ["mimic.fit.time_constant", "out of range"]),
    ("mode: mirror\n", ["mimic.mode", "did you mean 'mirrored'"]),
    ("relative_to: nose\n", ["mimic.relative_to", "unknown human target 'nose'"]),
    ("gaze: {enabled: true, target: nose}\n", ["mimic.gaze.target", "'nose'"]),
    ("interpolation: {mode: predict}\n", ["mimic.interpolation.mode", "hold", "extrapolate"]),
    ("servo_rate: 300\n", ["mimic.servo_rate", "must divide", "420"]),
    ("perception: tracked\n", ["mimic.perception", "filter"]),
])
def test_bad_mimic_section_exits_2_naming_the_key(tmp_path, capsys, mimic, must_contain):
    code, err = _run(tmp_path, capsys, mimic)
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    for piece in must_contain:
        assert piece in err, f"{piece!r} not in {err!r}"


def test_defaults_per_mode():
    assert MimicConfig().map == {"right_hand": "R_palm"}
    assert MimicConfig(mode="mirrored").map == {"right_hand": "L_palm"}
    assert MimicConfig(mode="follow").map == {"head": "R_palm"}
    cfg = MimicConfig(relative_to="pelvis", gaze={"enabled": True, "target": "head"})
    assert cfg.targets == ["right_hand", "pelvis", "head"]
