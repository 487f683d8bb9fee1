"""Nested ``metrics.json`` sections as flat dotted keys: the one flattener that the summary
table, the report page and the sweep's CSV columns share."""

from __future__ import annotations

from typing import Any


def flatten_metrics(value: Any, prefix: str = "", max_depth: int | None = None,
                    lists: bool = True) -> dict[str, Any]:
    """Nested dicts (and lists, as ``key.0``, ``key.1`` ...) to ``{dotted.key: scalar}``.

    ``max_depth``: leave out scalars more than this many keys deep; ``lists=False``: leave out
    lists. Order follows the input's."""
    out: dict[str, Any] = {}
    if isinstance(value, dict):
        items = [(str(k), v) for k, v in value.items()]
    elif isinstance(value, list | tuple):
        if not lists:
            return out
        items = [(str(i), v) for i, v in enumerate(value)]
    else:
        return {prefix[:-1]: value}
    if max_depth is not None and prefix.count(".") >= max_depth:
        return out
    for k, v in items:
        out.update(flatten_metrics(v, f"{prefix}{k}.", max_depth, lists))
    return out
