"""``trackers:`` -- the scenario's trackers, by name, each with a ``kind``.

:data:`TrackerConfig` is the discriminated union over ``kind`` of the tracker kinds' config
classes (one import and one union member per kind, each kind's config in its own package
``perception/trackers/<kind>/``). Several trackers may run side by side on the same frames.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from humimic.perception.trackers.gest.config import GestConfig
from humimic.perception.trackers.hand2d.config import Hand2DConfig
from humimic.perception.trackers.icu.config import IcuConfig
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.tbp.config import TbpConfig

TrackerConfig = Annotated[
    Hand2DConfig
    | IcuConfig
    | GestConfig
    | TbpConfig
    | KpfConfig,
    Field(discriminator="kind"),
]
