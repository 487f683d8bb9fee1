"""``TrackerConfig``: the scenario's ``trackers:`` values, a union discriminated by ``kind``
(one import and one union member per tracker kind)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from humimic.perception.trackers.gest.config import GestConfig
from humimic.perception.trackers.tbp.config import TbpConfig

TrackerConfig = Annotated[
    GestConfig
    | TbpConfig,
    Field(discriminator="kind"),
]
