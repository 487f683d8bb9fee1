"""Other people in the lab (``human.people``): more avatars, each with a face, clothes and a
scripted walk, for trackers that must follow one person among several (Menezes Figs. 9-10).

Each person is the avatar model attached again (names prefixed ``person<i>/``), standing
upright and facing the robot like the tutor; only their root moves, through timed waypoints
``(distance, lateral)`` in the lab's placement convention (``human.distance`` / ``lateral``:
metres ahead of the robot's eyes and to its left), at rest at each waypoint (minimum jerk in
between). Their ground truth (the head's position) is analytic: the head at the start pose
moved with the root.
"""

from __future__ import annotations

import math

import numpy as np
from dm_control import mjcf
from pydantic import Field, field_validator

from humimic.motion.primitives import min_jerk
from humimic.scenario.base import RGB, Section

PERSON_PREFIX = "person"
SKIN_SITES = ("head", "r_hand", "l_hand")
"""The sites of a person's skin (face and hands): what a skin-based tracker may mistake."""


class PersonWaypoint(Section):
    t: float = Field(ge=0.0)
    """When the person stands here (s)."""
    at: tuple[float, float]
    """``(distance, lateral)`` (m): ahead of the robot's eyes, to its left."""

    @field_validator("at")
    @classmethod
    def _in_the_lab(cls, v):
        if not (0.3 < v[0] <= 4.5 and -3.0 <= v[1] <= 3.0):
            raise ValueError("distance must be in (0.3, 4.5] m and lateral in [-3, 3] m")
        return v


class Person(Section):
    """Another person: a face, clothes and a walk."""

    identity: str
    """A face of :data:`humimic.world.faces.IDENTITY_NAMES` (or its index)."""
    skin: RGB = (0.76, 0.57, 0.45)
    shirt: RGB = (0.75, 0.2, 0.2)
    trousers: RGB = (0.3, 0.3, 0.25)
    waypoints: list[PersonWaypoint] = Field(min_length=1, max_length=50)

    @field_validator("identity", mode="before")
    @classmethod
    def _known_identity(cls, v):
        from humimic.world.config import check_identity

        return check_identity(v)

    @field_validator("waypoints")
    @classmethod
    def _increasing(cls, v):
        if any(b.t <= a.t for a, b in zip(v, v[1:], strict=False)):
            raise ValueError("waypoint times must increase")
        return v


def position(waypoints, t: np.ndarray) -> np.ndarray:
    """``(distance, lateral)`` at times ``t`` ``(F,)`` -> ``(F, 2)``: held before the first
    and after the last waypoint, minimum jerk between consecutive ones."""
    t = np.atleast_1d(np.asarray(t, float))
    ts = np.array([w.t for w in waypoints])
    at = np.array([w.at for w in waypoints], float)
    out = np.repeat(at[:1], len(t), axis=0)
    for k in range(1, len(ts)):
        u = (t - ts[k - 1]) / (ts[k] - ts[k - 1])
        seg = (t >= ts[k - 1])
        out[seg] = at[k - 1] + min_jerk(u[seg])[:, None] * (at[k] - at[k - 1])
    return out


def attach_people(room: mjcf.RootElement, people, eye_x: float, add_face) -> None:
    """Attach one avatar per person at its first waypoint, facing the robot."""
    from humimic.paths import MODELS_DIR

    for i, person in enumerate(people, start=1):
        model = mjcf.from_path(str(MODELS_DIR / "avatar.xml"))
        model.model = f"{PERSON_PREFIX}{i}"
        for name, rgb in (("skin", person.skin), ("shirt", person.shirt),
                          ("trousers", person.trousers)):
            model.find("material", name).rgba = [*rgb, 1.0]
        add_face(model, person.identity)
        model.find("geom", "headcam").group = 4  # hidden
        d, lat = person.waypoints[0].at
        frame = room.attach(model)
        frame.pos = [eye_x + d, lat, 0.0]
        frame.euler = [0.0, 0.0, math.pi]


class PeopleMotion:
    """Writes the people's root positions into ``qpos`` and gives their heads' truth."""

    def __init__(self, model, people):
        import mujoco

        self.people = list(people)
        self.adr, self.start = [], []
        self.sites0: list[dict[str, np.ndarray]] = []
        d = mujoco.MjData(model)
        mujoco.mj_kinematics(model, d)
        for i, p in enumerate(self.people, start=1):
            pre = f"{PERSON_PREFIX}{i}/"
            self.adr.append((model.jnt_qposadr[model.joint(pre + "root_x").id],
                             model.jnt_qposadr[model.joint(pre + "root_y").id]))
            self.sites0.append({site: d.site_xpos[model.site(pre + site).id].copy()
                                for site in SKIN_SITES})
            self.start.append(np.array(p.waypoints[0].at, float))

    def root_offsets(self, k: int, t: np.ndarray) -> np.ndarray:
        """Person ``k``'s ``(root_x, root_y)`` at ``t``: the avatar faces the robot (its +x
        is the world's -x, its +y the world's -y)."""
        dl = position(self.people[k].waypoints, t) - self.start[k]
        return np.column_stack([-dl[:, 0], -dl[:, 1]])

    def apply(self, qpos: np.ndarray, t: float) -> None:
        for k, (ax, ay) in enumerate(self.adr):
            qpos[ax], qpos[ay] = self.root_offsets(k, np.array([t]))[0]

    def site_world(self, k: int, site: str, t: np.ndarray) -> np.ndarray:
        """Person ``k``'s site (one of :data:`SKIN_SITES`) in the world ``(F, 3)`` at times
        ``t`` (the people only walk: their arms hang, so the site moves with the root)."""
        dl = position(self.people[k].waypoints, t) - self.start[k]
        return self.sites0[k][site] + np.column_stack([dl[:, 0], dl[:, 1], np.zeros(len(dl))])
