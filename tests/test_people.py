"""Other people in the room (human.people): their walk, their head's truth, their keys."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic.rngs import Rngs
from humimic.scenario.errors import ScenarioError
from humimic.scenario.load import validate_scenario
from humimic.world.people import PersonWaypoint, position


def test_walk_is_minimum_jerk_between_waypoints():
    wps = [PersonWaypoint(t=1.0, at=(2.0, 0.5)), PersonWaypoint(t=3.0, at=(2.0, -0.5))]
    t = np.array([0.0, 1.0, 1.5, 2.0, 3.0, 4.0])
    u = (t - 1.0) / 2.0
    s = np.clip(u, 0, 1) ** 3 * (10 - 15 * np.clip(u, 0, 1) + 6 * np.clip(u, 0, 1) ** 2)
    np.testing.assert_allclose(position(wps, t)[:, 1], 0.5 - s)
    np.testing.assert_allclose(position(wps, t)[:, 0], 2.0)


def _data(**person):
    return {"name": "t", "cameras": {"which": "foveal", "eyes": "left"},
            "human": {"people": [{"identity": "cyd", **person}]}}


def test_head_truth_is_where_mujoco_puts_the_head():
    from humimic.world.world import World

    data = _data(waypoints=[{"t": 0.0, "at": [1.8, 0.9]}, {"t": 0.5, "at": [1.5, -0.3]}])
    data["duration"] = 0.6
    world = World(validate_scenario(data), Rngs(0))
    try:
        m, d = world.scene.model, world.scene.data
        for tick in (0, 200, 420, 503):
            world.apply_human(tick)
            mujoco.mj_kinematics(m, d)
            t = np.array([world.times[tick]])
            for site in ("head", "r_hand", "l_hand"):  # the skin a hand tracker may mistake
                np.testing.assert_allclose(world.people.site_world(0, site, t)[0],
                                           d.site_xpos[m.site(f"person1/{site}").id],
                                           atol=1e-9)
    finally:
        world.close()


@pytest.mark.parametrize("person, key", [
    ({"identity": "zed", "waypoints": [{"t": 0, "at": [2, 0]}]}, "human.people.0.identity"),
    ({"waypoints": [{"t": 0, "at": [9, 0]}]}, "human.people.0.waypoints.0.at"),
    ({"waypoints": []}, "human.people.0.waypoints"),
])
def test_bad_people_name_the_key(person, key):
    data = _data(**person)
    data["human"]["people"][0].update(person)
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        validate_scenario(data)


def test_people_only_in_the_lab():
    data = _data(waypoints=[{"t": 0, "at": [2, 0]}])
    data["room"] = "sugiyama"
    with pytest.raises(ScenarioError, match=r"human\.people"):
        validate_scenario(data)
