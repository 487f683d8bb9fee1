"""The scripted person against the eyes' start view (:mod:`humimic.world.person_view`): the
summary against closed forms, and a CMU
clip whose own root travel walks the person through the robot (warned once, at build)."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.world.person_view import MIN_FRONT_DISTANCE_M, OUT_OF_VIEW, view_summary


def test_view_summary_against_closed_forms():
    t = np.arange(10) * 0.5
    seen = np.array([1, 1, 1, 0, 0, 1, 1, 1, 1, 1], bool)
    front = np.column_stack([np.linspace(1.2, 0.3, 10), np.full(10, 1.0)])
    s = view_summary(t, seen, front)
    assert s["out_of_view_fraction"] == pytest.approx(0.2) and s["first_out_of_view_s"] == 1.5
    assert s["min_front_distance_m"] == pytest.approx(0.3) and s["min_front_distance_t_s"] == 4.5
    assert "out of the eye cameras' start view on 20% of the run (from 1.5 s)" in s["warning"]
    assert "passes through" not in s["warning"]  # 0.3 m is not nearer than the bound
    s = view_summary(t, np.ones(10, bool), front - 1.0)
    assert s["out_of_view_fraction"] == 0.0 and s["first_out_of_view_s"] is None
    assert "passes through the robot (0.70 m behind its eyes at 4.5 s)" in s["warning"]
    assert view_summary(t, np.ones(10, bool), front)["warning"] is None
    assert OUT_OF_VIEW == 0.1 and MIN_FRONT_DISTANCE_M == 0.3  # the bounds these cases straddle


def _world(root, *overrides):
    from humimic.world.world import World

    sc = load_scenario(root / "scenarios" / "mimic_tracked_wave.yaml", list(overrides))
    world = World(sc, Rngs(sc.seed))
    world.close()
    return world.person_view


def test_a_clip_that_walks_the_person_through_the_robot_is_warned_once(root, caplog):
    """CMU 01_01 from its start at 1.2 m: its forward jumps carry the person past the robot
    (measured: out of the start view on 46 % of 61 samples from 3.3 s, the nearest 1.68 m
    behind the eyes at 6.0 s); the default wave stays 1.18 m in front, always in view."""
    clip = root / "data" / "mocap" / "cmu_01_01.bvh"
    with caplog.at_level(logging.WARNING, logger="humimic.world.person_view"):
        pv = _world(root, f"human.motion={{kind: bvh, file: {clip}}}")
    assert 0.25 <= pv["out_of_view_fraction"] <= 0.7
    assert -2.5 <= pv["min_front_distance_m"] <= -1.0
    assert "passes through the robot" in pv["warning"]
    assert [r.getMessage() for r in caplog.records] == [pv["warning"]]  # once, at build
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="humimic.world.person_view"):
        pv = _world(root)
    assert pv["warning"] is None and pv["out_of_view_fraction"] == 0.0
    assert pv["min_front_distance_m"] == pytest.approx(1.18, abs=0.05)  # measured 1.177
    assert not caplog.records
