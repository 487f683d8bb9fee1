"""Scenario field types the tracker kinds' configs share."""

from __future__ import annotations

from typing import Annotated

from pydantic import AfterValidator, Field


def _divides_256(v: int) -> int:
    if 256 % v:
        raise ValueError("must divide 256 (2, 4, 8, 16, 32, 64, 128, 256)")
    return v


Bins = Annotated[int, Field(ge=2, le=256), AfterValidator(_divides_256)]
"""Colour-histogram bins per 8-bit channel (:func:`humimic.perception.cues.histograms.quantize`
needs a divisor of 256)."""
