"""Read a scenario file, apply ``--set`` overrides, validate, resolve relative file paths."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from humimic.scenario.errors import ScenarioError, from_validation_error
from humimic.scenario.schema import Scenario


def parse_override(text: str) -> tuple[str, Any]:
    """``"human.distance=1.5"`` -> ``("human.distance", 1.5)`` (the value is read as YAML)."""
    if "=" not in text:
        raise ScenarioError("--set", text, "expected dotted.key=value", text)
    key, raw = text.split("=", 1)
    try:
        value = yaml.safe_load(raw) if raw.strip() else ""
    except yaml.YAMLError:
        value = raw
    return key.strip(), value


def apply_override(data: dict, key: str, value: Any) -> None:
    """Set ``data[a][b][c] = value`` for ``key = "a.b.c"`` (list indices as numbers).

    A missing or scalar section on the way becomes a mapping (``robot.pose.R_EB=1`` over
    ``pose: ready``); a path through a list needs an index within it, else a
    :class:`ScenarioError` naming the ``--set`` key."""
    parts = key.split(".")
    if not all(parts):
        raise ScenarioError("--set", key, "empty part in the dotted key", None,
                            "dotted.key=value, e.g. human.distance=1.5")
    node: Any = data
    for depth, part in enumerate(parts):
        if isinstance(node, list):
            if not (part.isdecimal() and int(part) < len(node)):
                where = ".".join(parts[:depth])
                raise ScenarioError("--set", key, f"{where} is a list of {len(node)}: no item "
                                    f"{part!r}", None, f"an index 0..{len(node) - 1}")
            index: Any = int(part)
            child = node[index]
        else:
            index, child = part, node.get(part)
        if depth == len(parts) - 1:
            node[index] = value
            return
        if not isinstance(child, (dict, list)):
            child = node[index] = {}
        node = child


def load_scenario(path: str | Path, overrides: list[str] | None = None,
                  **replace: Any) -> Scenario:
    """Load and validate ``path``. ``replace`` sets top-level keys (``seed=3``, ``duration=2``).

    Raises :class:`ScenarioError` (one line) for anything wrong with the input.
    """
    path = Path(path)
    text, data = read_yaml_mapping(path, "scenario", "a YAML file (see scenarios/)")
    return validate_scenario(data, path, text, overrides, **replace)


def read_yaml_mapping(path: Path, what: str, hint: str) -> tuple[str, dict]:
    """The text of a YAML file and its top-level mapping; :class:`ScenarioError` (one line,
    with the line number for a syntax error) if it is missing, not YAML or not a mapping."""
    if not path.is_file():
        raise ScenarioError(path, "", f"{what} file not found", str(path), hint)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(path, "", f"cannot read the {what} file ({exc.strerror})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(path, "", f"not a text file: byte {raw[exc.start]:#04x} at offset "
                            f"{exc.start} is not UTF-8", None, hint,
                            line=raw.count(b"\n", 0, exc.start) + 1) from None
    try:
        data = yaml.safe_load(text)
    except yaml.reader.ReaderError as exc:  # a character YAML does not allow
        raise ScenarioError(path, "", f"not valid YAML: character #x{exc.character:04x} is not "
                            "allowed", line=text.count("\n", 0, exc.position) + 1) from None
    except (yaml.YAMLError, RecursionError) as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = " ".join(str(getattr(exc, "problem", exc)).split())
        raise ScenarioError(path, "", f"not valid YAML: {problem}",
                            line=mark.line + 1 if mark else None) from None
    if not isinstance(data, dict):
        raise ScenarioError(path, "", f"a {what} must be a mapping of keys", data, hint)
    return text, data


def validate_scenario(data: dict, path: str | Path = "<scenario>", text: str = "",
                      overrides: list[str] | None = None, **replace: Any) -> Scenario:
    """Validate a scenario given as a dict (see :func:`load_scenario`)."""
    path = Path(path)
    for item in overrides or []:
        apply_override(data, *parse_override(item))
    for key, value in replace.items():
        if value is not None:
            data[key] = value
    overridden = command_line_keys(overrides, **replace)
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as err:
        raise from_validation_error(err, Scenario, path, text, overridden) from None
    resolve_paths(scenario, path.parent, path)
    return scenario


def command_line_keys(overrides: list[str] | None = None, **replace: Any) -> dict[str, str]:
    """Keys set on the command line -> the option that set them (``--set``, ``--seed``...)."""
    keys = {parse_override(item)[0]: "--set" for item in overrides or []}
    keys.update({key: f"--{key}" for key, value in replace.items() if value is not None})
    return keys


def placed(err: ScenarioError, name: str, path: str | Path, overrides: list[str] | None = None,
           **replace: Any) -> ScenarioError:
    """A check after loading names the scenario (``scenario 'wave'``); the same error placed
    in the file ``path`` it was loaded from: at its key's line, or the option that set it."""
    if err.file != f"scenario {name!r}":
        return err
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeError):
        text = ""
    return ScenarioError.placed(err, path, text, command_line_keys(overrides, **replace))


def resolve_paths(model: BaseModel, base_dir: Path, file: Path, prefix: str = "") -> None:
    """Resolve every ``Path`` field against ``base_dir`` and check the file exists."""
    for name in type(model).model_fields:
        value = getattr(model, name)
        key = f"{prefix}{name}"
        if isinstance(value, BaseModel):
            resolve_paths(value, base_dir, file, key + ".")
        elif isinstance(value, Path):
            resolved = value if value.is_absolute() else (base_dir / value).resolve()
            if not resolved.is_file():
                raise ScenarioError(file, key, "file not found", str(value),
                                    f"an existing file (relative paths are resolved against "
                                    f"{base_dir})")
            object.__setattr__(model, name, resolved)
        elif isinstance(value, list):
            for i, item in enumerate(value):
                if isinstance(item, BaseModel):
                    resolve_paths(item, base_dir, file, f"{key}.{i}.")


def dump_scenario(scenario: Scenario) -> str:
    """The fully resolved scenario as YAML (every default written out)."""
    return yaml.safe_dump(scenario.model_dump(mode="json"), sort_keys=False)
