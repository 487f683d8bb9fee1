"""Errors that are the user's input, not a bug: the CLI prints them as one line and exits 2."""

from __future__ import annotations


class InputError(Exception):
    """A problem with the user's scenario or files. ``str(err)`` is the whole message."""

    exit_code = 2
