"""The scenario file's schema: one pydantic model per section, unknown keys rejected.

Stages plug in by adding an optional section here (``perception``, ``filter``, ``mimic``...),
defined next to the stage in its own package. A scenario that omits a section does not run
that stage.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from humimic.control.commands_config import CommandsConfig
from humimic.control.config import MimicConfig
from humimic.estimation.config import FilterConfig
from humimic.estimation.ekf.arm_config import ArmConfig
from humimic.estimation.ekf.slam_config import SlamConfig
from humimic.perception.blobs.config import PerceptionConfig
from humimic.perception.trackers.config import TrackerConfig
from humimic.scenario.base import Section
from humimic.sensors.config import Cameras, Sensors, Timing
from humimic.viz.config import Output
from humimic.world.config import Human, Lighting, Robot


class Scenario(Section):
    """A whole run: world, sensors, stages and outputs. Units: m, s, rad unless a key says."""

    name: str = Field(pattern=r"^[A-Za-z0-9_.\-]+$", max_length=80)
    description: str = ""
    duration: float = Field(8.0, gt=0.0, le=600.0)
    """Simulated seconds."""
    seed: int = Field(0, ge=0)
    room: Literal["lab", "sugiyama", "lab_clutter"] = "lab"
    """The room (``models/``): ``lab``, Ude & Atkeson's, the person ``human.distance`` in front
    of the robot; ``sugiyama``, Sugiyama & Miura's wearable room (Fig. 5), the person starting
    at the paper's W (0, -2.5) facing the screen, the robot 2 m to their right;
    ``lab_clutter``, the lab with heavy clutter behind the person (Menezes Figs. 11, 13)."""
    human: Human = Field(default_factory=Human)
    robot: Robot = Field(default_factory=Robot)
    cameras: Cameras = Field(default_factory=Cameras)
    lighting: Lighting = Field(default_factory=Lighting)
    sensors: Sensors = Field(default_factory=Sensors)
    timing: Timing = Field(default_factory=Timing)
    output: Output = Field(default_factory=Output)
    perception: PerceptionConfig | None = None
    """Colour-blob stereo tracking (see :mod:`humimic.perception.blobs.config`); absent: none."""
    filter: FilterConfig | None = None
    """Random-jerk Kalman filter of perception's measurements (see
    :mod:`humimic.estimation.config`); needs ``perception``."""
    slam: SlamConfig | None = None
    """The wearer's head pose by EKF SLAM from the head camera and IMU (Sugiyama & Miura sec.
    III, see :mod:`humimic.estimation.ekf.slam_config`); needs those sensors."""
    mimic: MimicConfig | None = None
    """Imitation by the robot (see :mod:`humimic.control.config`); absent: the robot holds."""
    arm: ArmConfig | None = None
    """The Wii remote's pose in the head frame, Sugiyama & Miura's arm EKF (see
    :mod:`humimic.estimation.ekf.arm_config`); needs the head camera and the Wii remote."""
    commands: CommandsConfig | None = None
    """Robot commands from the wearer's motion and the robot following them (Sugiyama &
    Miura sec. V-C, :mod:`humimic.control.commands_config`); excludes ``mimic``."""
    trackers: dict[str, TrackerConfig] = Field(default_factory=dict)
    """Tracker stages by name, each with a ``kind`` (:mod:`humimic.perception.trackers`);
    several may run side by side on the same frames; scored as ``trackers.<name>.*``."""

    @model_validator(mode="after")
    def _placement_fits_the_room(self) -> Scenario:
        if self.room not in ("lab", "lab_clutter"):
            fields = Human.model_fields  # a resolved file repeats the defaults: not "given"
            given = [k for k in ("distance", "lateral", "people")
                     if k in self.human.model_fields_set and getattr(self.human, k)
                     != fields[k].get_default(call_default_factory=True)]
            if given:
                raise ValueError(f"human.{given[0]} does not apply in room {self.room!r}: the "
                                 "room places the person (move them with human.motion)")
        return self
