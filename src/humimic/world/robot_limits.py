"""The robot's joint limits read from its MJCF file, without compiling the scene (the scenario
schema checks ``robot.pose`` against them)."""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET

from humimic.paths import MODELS_DIR
from humimic.world.names import ROBOT_JOINTS

ROBOT_MJCF = MODELS_DIR / "db_humanoid.xml"


@functools.cache
def robot_joint_ranges() -> dict[str, tuple[float, float]]:
    """``{joint: (lower, upper)}`` (rad) of every robot joint in :data:`ROBOT_JOINTS`."""
    root = ET.parse(ROBOT_MJCF).getroot()
    ranges = {}
    for joint in root.iter("joint"):
        name = joint.get("name")
        if name in ROBOT_JOINTS and joint.get("range"):
            lo, hi = (float(x) for x in joint.get("range").split())
            ranges[name] = (lo, hi)
    return ranges
