"""Sweeps: many seeded runs of one scenario over a grid and/or list of overrides.

``python -m humimic.sweep SWEEP.yaml`` (see :mod:`humimic.sweep.__main__`). The pieces:
:mod:`~humimic.sweep.config` (the sweep file), :mod:`~humimic.sweep.grid` (named runs),
:mod:`~humimic.sweep.plan` (every scenario validated up front), :mod:`~humimic.sweep.runs`
(one resumable ``run_one`` call), :mod:`~humimic.sweep.backends` (joblib/loky or Ray),
:mod:`~humimic.sweep.summary` and :mod:`~humimic.sweep.plots` (the results),
:mod:`~humimic.sweep.driver` (all of it in order).
"""
