"""Errors that are the user's input, not a bug: the CLI prints them as one line and exits 2."""

from __future__ import annotations

import sys


class InputError(Exception):
    """A problem with the user's scenario or files. ``str(err)`` is the whole message."""

    exit_code = 2


def report_error(err: BaseException | str) -> int:
    """Print ``err`` as the single ``error: ...`` line a command gives for bad input (its
    whitespace, newlines included, collapsed) and return the exit code for it, 2."""
    print(f"error: {' '.join(str(err).split())}", file=sys.stderr)
    return InputError.exit_code
