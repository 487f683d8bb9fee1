"""What a run shows and saves: the rerun recording, its default layout and PNG plots.

* :class:`RerunLog` (:mod:`humimic.viz.rerun_log`) -- one run's rerun recording: scene, body
  poses, eye images, blobs, estimates, series and events against simulated time; a no-op
  when rerun is off. The entity layout is documented there. Its whole-run series and 3-D
  trails go out as columns in bounded chunks (:mod:`humimic.viz.rerun_columns`).
* :func:`default_blueprint` (:mod:`humimic.viz.blueprint`) -- the layout stored with it.
* :func:`plot_trajectories`, :func:`plot_errors`, :func:`plot_error_budget`
  (:mod:`humimic.viz.plots`) -- matplotlib PNGs.
* :mod:`humimic.viz.config` -- the scenario's ``output`` section.

Exports are resolved lazily, so importing :mod:`humimic.viz.config` (the scenario schema
does) does not pull in rerun and matplotlib.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "RerunLog": "rerun_log",
    "TIMELINE": "rerun_log",
    "WORLD": "rerun_log",
    "ROOM": "rerun_log",
    "BASE": "rerun_log",
    "CAMERAS": "rerun_log",
    "TRUTH": "rerun_log",
    "ESTIMATES": "rerun_log",
    "SERIES": "rerun_log",
    "EVENTS": "rerun_log",
    "body_entity": "rerun_log",
    "camera_entity": "rerun_log",
    "image_entity": "rerun_log",
    "default_blueprint": "blueprint",
    "plot_trajectories": "plots",
    "plot_errors": "plots",
    "plot_error_budget": "plots",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
