"""The default rerun layout of a run: the 3-D world, the eye images and the time series.

::

    +--------------------------------+---------------------+
    | 3-D: world (robot, avatar,     | series root 1       |
    | room, cameras, truth, estimates)| series root 2 ...  |
    +----------------+---------------+---------------------+
    | eye image 1    | eye image 2   | events (text log)   |
    +----------------+---------------+---------------------+

Pass it to :class:`humimic.viz.RerunLog` (``blueprint=``) so it is stored in the ``.rrd`` and
used when the file is opened.
"""

from __future__ import annotations

import rerun.blueprint as rrb

from humimic.viz.rerun_log import EVENTS, WORLD

#: A side view from inside the room, robot (x ~ 0) on the left, the person (x ~ 1.3) right.
EYE_POSITION_M = (0.7, -2.8, 1.8)
EYE_TARGET_M = (0.7, 0.0, 1.1)


def default_blueprint(camera_entities: list[str], series_roots: list[str],
                      events: str | None = EVENTS) -> rrb.Blueprint:
    """Layout with a 3-D view of ``world``, one 2-D view per camera, one plot per series root.

    ``camera_entities`` are camera pose entities (``world/cameras/L_wide``) or their image
    entities (``.../image``); each 2-D view shows the image with its overlays. ``series_roots``
    are entity subtrees of scalars (``series/tracking``); ``events`` a text-log subtree.
    """
    world = rrb.Spatial3DView(
        origin=WORLD, name="world",
        eye_controls=rrb.EyeControls3D(position=EYE_POSITION_M, look_target=EYE_TARGET_M,
                                       eye_up=(0.0, 0.0, 1.0)),
        line_grid=rrb.LineGrid3D(visible=False),  # the floor is drawn
    )
    images = [rrb.Spatial2DView(origin=_image_origin(e), name=_image_origin(e).split("/")[-2])
              for e in camera_entities]
    plots = [rrb.TimeSeriesView(origin=root, name=root.split("/")[-1] or root)
             for root in series_roots]
    left = rrb.Vertical(world, rrb.Horizontal(*images), row_shares=[3, 2]) if images else world
    right_parts = plots + ([rrb.TextLogView(origin=events, name="events")] if events else [])
    main = (rrb.Horizontal(left, rrb.Vertical(*right_parts), column_shares=[3, 2])
            if right_parts else left)
    # Side panels folded away; the time panel stays, it is how one scrubs a run.
    return rrb.Blueprint(main, rrb.BlueprintPanel(state="collapsed"),
                         rrb.SelectionPanel(state="collapsed"), rrb.TimePanel(state="expanded"))


def _image_origin(entity: str) -> str:
    entity = entity.rstrip("/")
    return entity if entity.endswith("/image") else f"{entity}/image"
