"""Errors that are the user's input, not a bug: the CLI prints them as one line and exits 2."""

from __future__ import annotations

import difflib
import sys
from collections.abc import Iterable


class InputError(Exception):
    """A problem with the user's scenario or files. ``str(err)`` is the whole message."""

    exit_code = 2


def report_error(err: BaseException | str) -> int:
    """Print ``err`` as the single ``error: ...`` line a command gives for bad input (its
    whitespace, newlines included, collapsed) and return the exit code for it, 2."""
    print(f"error: {' '.join(str(err).split())}", file=sys.stderr)
    return InputError.exit_code


def closest(word: object, options: Iterable[object]) -> str | None:
    """The option closest to ``word`` ignoring case (difflib, ratio >= 0.5), or None."""
    by_lower = {str(o).lower(): str(o) for o in options}
    close = difflib.get_close_matches(str(word).lower(), list(by_lower), n=1, cutoff=0.5)
    return by_lower[close[0]] if close else None


def unknown_name(what: str, name: object, allowed: Iterable[object]) -> ValueError:
    """The error for a name that is not one of ``allowed``: the names allowed and, when one is
    close, a did-you-mean (``unknown human target 'rigt_hand'; allowed: ...; did you mean
    'right_hand'?``)."""
    allowed = [str(a) for a in allowed]
    hint = closest(name, allowed)
    return ValueError(f"unknown {what} {name!r}; allowed: {', '.join(allowed)}"
                      + (f"; did you mean '{hint}'?" if hint else ""))
