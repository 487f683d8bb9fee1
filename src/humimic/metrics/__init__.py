"""Scores against ground truth, and the end-of-run summary.

Scores are computed in SI units and converted at the ``metrics.json`` boundary, where a number
that is undefined (no data: NaN) becomes ``null``: :func:`mm` for lengths in millimetres,
:func:`humimic.maths.stats.finite_or_none` for the rest.
"""

from humimic.maths.stats import finite_or_none


def mm(x) -> float | None:
    """Metres (or seconds) times 1000 for ``metrics.json``: mm (ms); None if not finite."""
    x = finite_or_none(x)
    return None if x is None else 1e3 * x
