"""Turn a pydantic validation error into one clear line.

The line names the file (and line), the dotted key, the value given, what is allowed and,
when a close match exists, a did-you-mean. Example::

    scenarios/wave.yaml:7: human.motion.amplitud: unknown key (value 0.3); allowed: amplitude,
    center, hand, kind, period; did you mean 'amplitude'?
"""

from __future__ import annotations

import re
import types
import typing
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from humimic.errors import InputError, closest


class ScenarioError(InputError):
    """A bad scenario. ``str()`` is the one-line message."""

    def __init__(self, file: str | Path, key: str, problem: str, value: Any = None,
                 allowed: str | None = None, suggestion: str | None = None,
                 line: int | None = None):
        self.file, self.key, self.problem = str(file), key, problem
        self.value, self.allowed, self.suggestion, self.line = value, allowed, suggestion, line
        where = f"{self.file}:{line}" if line else self.file
        parts = [f"{where}: {key or '<top level>'}: {problem}"]
        if value is not None:
            parts[0] += f" (got {_short(value)})"
        if allowed:
            parts.append(f"allowed: {allowed}")
        if suggestion:
            parts.append(f"did you mean '{suggestion}'?")
        super().__init__("; ".join(parts))


    @classmethod
    def placed(cls, err: ScenarioError, file: str | Path, text: str,
               overridden: dict[str, str]) -> ScenarioError:
        """``err`` re-said for ``file`` (whose YAML is ``text``): at its key's line, or
        naming the command-line option that set the key (``overridden``: key -> option)."""
        option = command_line_source(err.key, overridden)
        source = f"{file} ({option})" if option else file
        line = None if option else yaml_line(text, err.key.split("."))
        return cls(source, err.key, err.problem, err.value, err.allowed, err.suggestion, line)


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _unwrap(tp: Any) -> list[Any]:
    """The concrete types inside Optional / Union / Annotated."""
    origin = typing.get_origin(tp)
    if origin is typing.Annotated:
        return _unwrap(typing.get_args(tp)[0])
    if origin in (typing.Union, types.UnionType):
        out = []
        for arg in typing.get_args(tp):
            out.extend(_unwrap(arg))
        return out
    return [tp]


def _models_in(tp: Any) -> list[type[BaseModel]]:
    return [t for t in _unwrap(tp) if isinstance(t, type) and issubclass(t, BaseModel)]


def _tag_of(model: type[BaseModel]) -> str | None:
    field = model.model_fields.get("kind")
    if field is None:
        return None
    args = typing.get_args(field.annotation)
    return args[0] if args else None


def _tagged(models: list[type[BaseModel]], part: Any) -> type[BaseModel] | None:
    """The union member whose ``kind`` tag ``part`` is: pydantic puts the tag in a
    discriminated union's error locations (a one-member union's too)."""
    if not isinstance(part, str) or (len(models) == 1 and part in models[0].model_fields):
        return None
    match = [m for m in models if _tag_of(m) == part]
    return match[0] if match else None


def model_at(root: type[BaseModel], loc: tuple) -> type[BaseModel] | None:
    """The pydantic model that owns the last element of ``loc`` (for listing allowed keys)."""
    current: Any = root
    for part in loc[:-1]:
        models = _models_in(current)
        if models and isinstance(part, str):
            tagged = _tagged(models, part)  # discriminated union: the location names the tag
            if tagged is not None:
                current = tagged
                continue
            model = models[0]
            if part in model.model_fields:
                current = model.model_fields[part].annotation
                continue
            return None
        # list / tuple / dict element
        inner = [a for t in _unwrap(current) for a in typing.get_args(t)]
        if not inner:
            return None
        current = inner[-1]
    models = _models_in(current)
    if len(models) == 1:
        return models[0]
    return None


#: How pydantic names the member of a plain union in an error's location.
_UNION_TAG = re.compile(r"(constrained-)?(float|int|str|bool|none)|[a-z-]+\[.*\]")


def _dotted(loc: tuple, root: type[BaseModel]) -> str:
    """Dotted key for a pydantic location, dropping discriminator tags (``motion.wave.x``)."""
    parts: list[str] = []
    current: Any = root
    for part in loc:
        models = _models_in(current)
        tagged = _tagged(models, part)
        if tagged is not None:
            current = tagged
            continue
        if (isinstance(part, str) and not models and len(_unwrap(current)) > 1
                and _UNION_TAG.fullmatch(part)):
            continue  # a plain union's member tag ('constrained-float', "literal['x']")
        parts.append(str(part))
        if models and isinstance(part, str) and part in models[0].model_fields:
            current = models[0].model_fields[part].annotation
        else:
            inner = [a for t in _unwrap(current) for a in typing.get_args(t)]
            current = inner[-1] if inner else None
    return ".".join(parts)


def yaml_line(text: str, key_path: list[str]) -> int | None:
    """1-based line of a dotted key in YAML text (the deepest part of it that exists)."""
    try:
        node = yaml.compose(text)
    except yaml.YAMLError:
        return None
    line = None
    for part in key_path:
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                if k.value == part:
                    line, node = k.start_mark.line + 1, v
                    break
            else:
                return line
        elif (isinstance(node, yaml.SequenceNode) and part.isdecimal()
              and int(part) < len(node.value)):
            node = node.value[int(part)]
            line = node.start_mark.line + 1
        else:
            return line
    return line


def command_line_source(key: str, overridden: dict[str, str] | set[str]) -> str | None:
    """The command-line option that set ``key``, a key inside it or a section holding it."""
    options = overridden if isinstance(overridden, dict) else dict.fromkeys(overridden, "--set")
    for k, option in options.items():
        if key == k or key.startswith(k + ".") or k.startswith(key + "."):
            return option
    return None


#: Keys renamed since, to what a scenario should say now (the did-you-mean of an unknown key):
#: every particle filter's size is ``n_particles``.
RENAMED = {"n": "n_particles", "particles": "n_particles"}

_BOUNDS = {"greater_than": "> {gt}", "greater_than_equal": ">= {ge}", "less_than": "< {lt}",
           "less_than_equal": "<= {le}"}


def from_validation_error(err: ValidationError, root: type[BaseModel], file: str | Path,
                          text: str = "", overridden: dict[str, str] | set[str] | None = None
                          ) -> ScenarioError:
    """The first error of ``err`` as a :class:`ScenarioError`. ``overridden`` maps keys set on
    the command line to the option that set them (``{"duration": "--duration"}``; a set means
    ``--set``): an error at, inside or above such a key names the option, not a file line."""
    e = err.errors()[0]
    loc, kind, ctx = tuple(e["loc"]), e["type"], e.get("ctx", {}) or {}
    key = _dotted(loc, root)
    value = e.get("input")
    line = yaml_line(text, key.split(".")) if text else None
    source = file
    option = command_line_source(key, overridden or {})
    if option:
        source, line = f"{file} ({option})", None

    if kind == "extra_forbidden":
        model = model_at(root, loc)
        options = sorted(model.model_fields) if model else []
        hint = RENAMED.get(str(loc[-1]))
        return ScenarioError(source, key, "unknown key", value, ", ".join(options) or None,
                             hint if hint in options else closest(loc[-1], options), line)
    if kind == "literal_error":
        expected = ctx.get("expected", "")
        options = [o.strip().strip("'") for o in str(expected).replace(" or ", ",").split(",")]
        return ScenarioError(source, key, "not an allowed value", value, expected,
                             closest(value, options) if isinstance(value, str) else None, line)
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        expected = ctx.get("expected_tags", "")
        options = [o.strip().strip("'") for o in str(expected).split(",")]
        tag = ctx.get("tag")
        key = f"{key}.kind" if key else "kind"
        problem = "unknown kind" if kind == "union_tag_invalid" else "missing 'kind'"
        return ScenarioError(source, key, problem, tag, expected,
                             closest(tag, options) if tag else None, line)
    if kind == "missing":
        return ScenarioError(source, key, "required key is missing", None, None, None, line)
    if kind in _BOUNDS:
        return ScenarioError(source, key, "out of range", value, _BOUNDS[kind].format(**ctx),
                             None, line)
    message = e["msg"].removeprefix("Value error, ")
    if kind == "value_error" and (isinstance(value, dict)  # a section's own check (a model
                                  or repr(value) in message):  # validator) names its values
        value = None
    return ScenarioError(source, key, message, value, None, None, line)
