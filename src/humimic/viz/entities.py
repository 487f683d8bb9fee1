"""Names of what a run's rerun recording holds: entity paths, the timeline, display colours.

Entity layout (see :mod:`humimic.viz.rerun_log` for how each is logged)::

    world                         z-up world frame; world/room/..., world/db/..., world/human/...
    world/base                    the robot base frame
    world/cameras/{cam}[/image]   eye-camera pose (OpenCV axes) and its pinhole image
    world/truth/..., world/estimates/...   points, ellipsoids, arrows in world coordinates
    series/...                    scalar time series         events/...   text logs
    series/visibility/{target}/{unoccluded,size_px}   visibility ground truth, a line per eye
"""

from __future__ import annotations

from typing import Literal

import mujoco

#: Display colour (RGB) of each tracked target, everywhere it is drawn.
TARGET_COLORS = {"head": (255, 210, 0), "right_hand": (230, 40, 40),
                 "left_hand": (40, 200, 60)}
OTHER_COLOR = (200, 200, 200)
#: Line colours of x, y, z in time series.
AXIS_RGB = ((214, 39, 40), (44, 160, 44), (31, 119, 180))

TIMELINE = "sim_time"
#: Add to OpenCV pixel coordinates (pixel centres at integers) to place them on a rerun image
#: (pixel centres at +0.5): every 2-D overlay and the pinhole's principal point.
PIXEL_CENTRE_SHIFT = 0.5
WORLD = "world"
ROOM = "world/room"
BASE = "world/base"
CAMERAS = "world/cameras"
TRUTH = "world/truth"
ESTIMATES = "world/estimates"
SERIES = "series"
EVENTS = "events"

Mode = Literal["off", "save", "spawn"]


def visibility_entity(target: str, quantity: str) -> str:
    """Series of a target's visibility ground truth (one line per eye camera), e.g.
    ``series/visibility/right_hand/unoccluded`` (fraction; 0 out of view) or ``.../size_px``."""
    return f"{SERIES}/visibility/{target}/{quantity}"


def camera_entity(name: str) -> str:
    """Entity of an eye camera's pose, e.g. ``world/cameras/L_wide``."""
    return f"{CAMERAS}/{name}"


def image_entity(name: str) -> str:
    """Entity of a camera's pinhole and image (the origin of its 2-D view)."""
    return f"{camera_entity(name)}/image"


def body_entity(model: mujoco.MjModel, body_id: int) -> str:
    """Entity path of a MuJoCo body: ``world/db/torso``, ``world/room/screen``, ``world/room``."""
    if body_id == 0:
        return ROOM
    name = model.body(body_id).name.strip("/") or f"body{body_id}"
    return f"{WORLD}/{name}" if "/" in name else f"{ROOM}/{name}"
