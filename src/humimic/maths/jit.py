"""One place for how humimic compiles its hot loops with numba.

`njit` is `numba.njit` with the project's options: compiled code is cached on disk next to the
source (so only the first run after a change pays the compile time), releases the GIL (the
perception worker runs beside the servo loop), and keeps numpy's error model (division by zero
gives inf/nan like numpy instead of raising). No `parallel=True`: the machine has two cores and
the runner already uses both.
"""

from __future__ import annotations

import functools

import numba

njit = functools.partial(numba.njit, cache=True, nogil=True, error_model="numpy")
