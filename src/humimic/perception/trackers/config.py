"""``TrackerConfig``: the scenario's ``trackers:`` values, a union discriminated by ``kind``
(one import and one union member per tracker kind)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from humimic.perception.trackers.hand2d.config import Hand2DConfig
from humimic.perception.trackers.icu.config import IcuConfig

TrackerConfig = Annotated[
    Hand2DConfig | IcuConfig,
    Field(discriminator="kind"),
]
