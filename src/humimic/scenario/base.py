"""Shared building blocks for scenario sections (every section forbids unknown keys)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
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


def idle_options(cfg: BaseModel, needs: Mapping[str, tuple[str, ...]]
                 ) -> list[tuple[str, tuple[str, ...]]]:
    """The options of ``cfg`` moved from their defaults while none of the options they need
    (``needs``: option -> the options that switch it on; off is falsy: None, False, 0) is on,
    with those options: settings that would silently do nothing."""
    fields = type(cfg).model_fields
    return [(key, on) for key, on in needs.items()
            if getattr(cfg, key) != fields[key].get_default(call_default_factory=True)
            and not any(getattr(cfg, k) for k in on)]


def reject_idle_options(cfg: BaseModel, needs: Mapping[str, tuple[str, ...]]) -> None:
    """Raise (a validator's ValueError, naming both keys) on the first of
    :func:`idle_options`."""
    for key, on in idle_options(cfg, needs)[:1]:
        raise ValueError(f"{key} = {getattr(cfg, key)!r} has no effect without "
                         f"{' or '.join(on)} (set {on[0]} or leave {key} out)")
