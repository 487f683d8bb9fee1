"""Scenario section for what a run writes and shows."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from humimic.scenario.base import Section


class Output(Section):
    rerun: Literal["off", "save", "spawn"] = "save"
    """off: no recording; save: write run.rrd; spawn: also open the rerun viewer."""

    @field_validator("rerun", mode="before")
    @classmethod
    def _yaml_off(cls, value):
        """YAML 1.1 reads a bare ``off`` as ``false``: take it as meant."""
        return "off" if value is False else value
    image_every: int = Field(2, ge=0, le=1000)
    """Log every n-th camera frame to rerun (0: none). Images dominate the .rrd size."""
    jpeg_quality: int = Field(80, ge=10, le=100)
    pose_rate: float = Field(30.0, gt=0.0, le=840.0)
    """Rate (Hz) at which body poses are logged to rerun."""
    plots: bool = True
    """Write PNG plots next to metrics.json."""
