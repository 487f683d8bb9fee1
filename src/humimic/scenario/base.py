"""Shared building blocks for scenario sections (every section forbids unknown keys)."""

from __future__ import annotations

import dataclasses
from typing import Annotated, TypeVar

from pydantic import BaseModel, ConfigDict, Field


class Section(BaseModel):
    """Base of every scenario section: unknown keys are errors, values are validated on set,
    numbers are finite (``.nan`` and ``.inf`` are errors)."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)


Unit = Annotated[float, Field(ge=0.0, le=1.0)]
RGB = tuple[Unit, Unit, Unit]
Vec3 = tuple[float, float, float]
PositiveFloat = Annotated[float, Field(gt=0.0)]
NonNegativeFloat = Annotated[float, Field(ge=0.0)]


P = TypeVar("P")


def pass_through(params_cls: type[P], cfg: BaseModel) -> P:
    """``params_cls`` (a dataclass of an algorithm's parameters) from a config section: every
    dataclass field that the section has, under the same name (one name per option; the
    dataclass's other fields keep their defaults)."""
    keys = [f.name for f in dataclasses.fields(params_cls) if f.name in type(cfg).model_fields]
    return params_cls(**{k: getattr(cfg, k) for k in keys})
