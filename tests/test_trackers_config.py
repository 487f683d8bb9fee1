"""Bad ``trackers:`` and ``mimic.mode: joints`` input: exit status 2, one line naming the key."""

from __future__ import annotations

import pytest
from test_scenario_errors import GOOD, _run


@pytest.mark.parametrize("text, must_contain", [
    (GOOD + "trackers:\n  g: {kind: gest, n_particles: 0}\n",
     ["trackers.g.n_particles", "out of range"]),
    (GOOD + "trackers:\n  x: {kind: gset}\n", ["trackers.x.kind", "'gset'"]),
    *[(GOOD + f"trackers:\n  t: {{kind: {kind}, {old}: 100}}\n",
       [f"trackers.t.{old}", "unknown key", "did you mean 'n_particles'"])
      for kind, old in (("gest", "n"), ("tbp", "n"), ("kpf", "particles"), ("icu", "particles"))],
    (GOOD + "trackers:\n  g: {kind: gest, alpha: 0.6, beta: 0.6}\n", ["trackers.g", "alpha"]),
    (GOOD + "trackers:\n  t: {kind: tbp, torso: truth, camera: nope}\n",
     ["trackers.t.camera", "'nope'", "not rendered"]),
    (GOOD + "trackers:\n  t: {kind: tbp}\n", ["trackers.t.torso", "perception"]),
    (GOOD + "mimic: {mode: joints}\n", ["mimic.mode", "joints", "tbp"]),
    (GOOD + "trackers:\n  t: {kind: tbp, torso: truth, limits: {R_EB_deg: [150, 0]}}\n",
     ["trackers.t.limits.R_EB_deg"]),
])
def test_bad_tracker_input_exits_2_naming_the_key(tmp_path, capsys, text, must_contain):
    code, err = _run(tmp_path, text, capsys=capsys)
    assert code == 2
    assert len(err.splitlines()) == 1, err
    for piece in must_contain:
        assert piece in err, f"{piece!r} not in {err!r}"
