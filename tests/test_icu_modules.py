"""Fig. 15's module switch (Menezes sec. 7.1.2): distance from the head width, the transitions
with hysteresis, the scores against the true distance, the gating of the near module, and its
scenario keys."""

from __future__ import annotations

import math

import numpy as np
import pytest

from humimic.perception.trackers.icu.modules import (
    GatedStage,
    head_distance_m,
    module_scores,
    next_module,
)
from humimic.pipeline.bus import Bus
from humimic.scenario.errors import ScenarioError
from humimic.scenario.load import validate_scenario
from humimic.sensors.camera_model import Intrinsics
from humimic.stamped import Stamped


def test_head_distance_inverts_the_projection():
    intr = Intrinsics.from_fovy(math.radians(18.3), 320, 240)
    for z in (1.0, 2.5, 4.0):
        left, right = intr.project(np.array([-0.078, 0.1, z])), intr.project(
            np.array([0.078, 0.1, z]))
        assert head_distance_m(intr.fx, right[0] - left[0], 0.156) == pytest.approx(z, rel=1e-9)
    assert head_distance_m(intr.fx, 0.0, 0.156) == math.inf


def test_transitions_need_recognition_and_have_hysteresis():
    seq = [(True, 3.0), (True, 1.6), (True, 1.45), (True, 1.6), (True, 1.79), (True, 1.81),
           (True, 1.49), (False, 1.2), (True, 1.2)]
    m, out = "init", []
    for tracked, d in seq:
        m = next_module(m, tracked, d, 1.5, 1.8)
        out.append(m)
    assert out == ["icu", "icu", "near", "near", "near", "icu", "near", "init", "near"]


def test_scores_count_agreement_and_delays():
    t = np.arange(8) * 0.1
    true_m = np.array([3.0, 2.0, 1.4, 1.3, 1.3, 1.6, 1.9, 2.0])
    mods = ["init", "icu", "icu", "near", "near", "near", "near", "icu"]
    vis = np.ones(8, bool)
    s = module_scores(t, mods, true_m, vis, 1.5, 1.8)
    # judged: all but t=0.5 (1.6 in the band); right: 1, 3, 4, 7 of 0, 1, 2, 3, 4, 6, 7
    assert s["agreement"] == pytest.approx(4 / 7)
    assert s["switch_delay_s"] == pytest.approx([0.1, 0.1])
    assert s["frames"] == {"init": 1, "icu": 3, "near": 4}
    assert [sw[1:] for sw in s["switches"]] == [["init", "icu"], ["icu", "near"], ["near", "icu"]]


def test_gated_stage_gets_frames_only_while_open():
    class Counter:
        name, got = "trackers.x", []

        def attach(self, bus, timer):
            bus.subscribe("frames", lambda tp, msg: self.got.append(msg.t))

    inner, state = Counter(), {"open": False}
    gated = GatedStage(inner, lambda: state["open"])
    bus = Bus()
    gated.attach(bus, None)
    for k in range(4):
        state["open"] = k >= 2
        bus.publish("frames", Stamped(float(k), None))
        bus.deliver(float(k))
    assert inner.got == [2.0, 3.0] and gated.name == "trackers.x"


def _scenario(near, others=True):
    trackers = {"icu": {"kind": "icu", "near": near}}
    if others:
        trackers["tbp"] = {"kind": "tbp", "torso": "truth"}
    data = {"name": "t", "cameras": {"which": "foveal", "eyes": "left"}, "trackers": trackers}
    return validate_scenario(data, "t.yaml")


def test_bad_near_keys_name_the_key():
    with pytest.raises(ScenarioError, match=r"trackers\.icu\.near\.leave_m: .*enter_m \(2\)"):
        _scenario({"module": "tbp", "enter_m": 2.0, "leave_m": 1.5})
    from humimic.perception.trackers.icu.build import icu_stage

    class World:
        eye_cameras = ["L_foveal"]

    for module in ("icu", "nobody"):
        sc = _scenario({"module": module})
        with pytest.raises(ScenarioError, match=r"trackers\.icu\.near\.module"):
            icu_stage("icu", sc.trackers["icu"], sc, World(), {}, None)
