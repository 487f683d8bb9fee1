"""Build the stages of the scenario's ``trackers:`` section, dispatching on ``kind``."""

from __future__ import annotations

from humimic.pipeline.stage import Stage


def _hand2d(name, cfg, scenario, world, rngs, rlog) -> Stage:
    from humimic.perception.trackers.hand2d.build import hand2d_stage

    return hand2d_stage(name, cfg, scenario, world, rngs, rlog)


def _icu(name, cfg, scenario, world, rngs, rlog) -> Stage:
    from humimic.perception.trackers.icu.build import icu_stage

    return icu_stage(name, cfg, scenario, world, rngs, rlog)


BUILDERS = {
    "hand2d": _hand2d,
    "icu": _icu,
}


def tracker_stages(scenario, world, rngs, rlog) -> list[Stage]:
    """One stage per entry of ``trackers:`` (in the file's order)."""
    return [BUILDERS[cfg.kind](name, cfg, scenario, world, rngs, rlog)
            for name, cfg in getattr(scenario, "trackers", {}).items()]
