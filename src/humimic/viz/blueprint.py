"""The default rerun layout of a run: the 3-D world, the eye images and the time series.

::

    +--------------------------------+---------------------+
    | 3-D: world (robot, avatar,     | time series view 1  |
    | room, cameras, truth, estimates)| time series view 2 |
    +----------------+---------------+---------------------+
    | eye image 1    | eye image 2   | events (text log)   |
    +----------------+---------------+---------------------+

:func:`run_layout` picks the views from what a run logged (so no view is empty): one error
plot per tracked target (``series/tracking/<target>``), one per mimicking robot site
(``series/mimicry/<site>/error_mm``), the ground truth when there is neither, the eye images
and the events that were logged. Send it with :meth:`humimic.viz.RerunLog.send_blueprint`.
"""

from __future__ import annotations

import rerun.blueprint as rrb

from humimic.viz.rerun_log import EVENTS, SERIES, WORLD

#: Over the robot's right shoulder, behind and above it, towards the person (x ~ 1.2 m):
#: the person's hand and the robot's copy both move across the view (not along it).
EYE_POSITION_M = (-1.4, -1.3, 2.4)
EYE_TARGET_M = (0.7, 0.1, 1.3)


def default_blueprint(camera_entities: list[str], series_views: list[tuple[str, str]],
                      events: str | None = EVENTS) -> rrb.Blueprint:
    """Layout with a 3-D view of ``world``, one 2-D view per camera, one plot per
    ``(origin, name)`` in ``series_views`` and a text-log view of ``events`` (None: none).

    ``camera_entities`` are camera pose entities (``world/cameras/L_wide``) or their image
    entities (``.../image``); each 2-D view shows the image with its overlays.
    """
    world = rrb.Spatial3DView(
        origin=WORLD, name="world",
        eye_controls=rrb.EyeControls3D(position=EYE_POSITION_M, look_target=EYE_TARGET_M,
                                       eye_up=(0.0, 0.0, 1.0)),
        line_grid=rrb.LineGrid3D(visible=False),  # the floor is drawn
    )
    images = [rrb.Spatial2DView(origin=_image_origin(e), name=_image_origin(e).split("/")[-2])
              for e in camera_entities]
    plots = [rrb.TimeSeriesView(origin=origin, name=name) for origin, name in series_views]
    left = rrb.Vertical(world, rrb.Horizontal(*images), row_shares=[3, 2]) if images else world
    right_parts = plots + ([rrb.TextLogView(origin=events, name="events")] if events else [])
    main = (rrb.Horizontal(left, rrb.Vertical(*right_parts), column_shares=[3, 2])
            if right_parts else left)
    # Side panels folded away; the time panel stays, it is how one scrubs a run.
    return rrb.Blueprint(main, rrb.BlueprintPanel(state="collapsed"),
                         rrb.SelectionPanel(state="collapsed"), rrb.TimePanel(state="expanded"))


def series_views(logged: set[str]) -> list[tuple[str, str]]:
    """``(origin, name)`` of the time-series views worth showing for the ``logged`` entities."""
    def roots(prefix: str, depth: int) -> list[str]:
        return sorted({"/".join(e.split("/")[:depth]) for e in logged
                       if e.startswith(prefix + "/")})

    views = [(r, f"{r.split('/')[-1]}: 3-D error (mm)") for r in roots(f"{SERIES}/tracking", 3)]
    views += [(f"{r}/error_mm", f"{r.split('/')[-1]}: error vs the mapped truth (mm)")
              for r in roots(f"{SERIES}/mimicry", 3) if f"{r}/error_mm" in logged]
    if not views and any(e.startswith(f"{SERIES}/ground_truth/") for e in logged):
        views.append((f"{SERIES}/ground_truth", "ground truth, base frame (m)"))
    return views


def run_layout(logged: set[str], camera_entities: list[str]) -> rrb.Blueprint:
    """:func:`default_blueprint` with the cameras, series and events that were ``logged``."""
    cams = [e for e in camera_entities if _image_origin(e) in logged]
    events = EVENTS if any(e.startswith(EVENTS + "/") for e in logged) else None
    return default_blueprint(cams, series_views(logged), events)


def _image_origin(entity: str) -> str:
    entity = entity.rstrip("/")
    return entity if entity.endswith("/image") else f"{entity}/image"
