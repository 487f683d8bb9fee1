"""Build the stages of the scenario's ``trackers:`` section, dispatching on ``kind``."""

from __future__ import annotations

from humimic.pipeline.stage import Stage


def _gest(name, cfg, scenario, world, rngs, rlog) -> Stage:
    from humimic.perception.trackers.gest.build import gest_stage

    return gest_stage(name, cfg, scenario, world, rngs, rlog)


def _tbp(name, cfg, scenario, world, rngs, rlog) -> Stage:
    from humimic.perception.trackers.tbp.build import tbp_stage

    return tbp_stage(name, cfg, scenario, world, rngs, rlog)


BUILDERS = {
    "gest": _gest,
    "tbp": _tbp,
}


def tracker_stages(scenario, world, rngs, rlog) -> list[Stage]:
    """One stage per entry of ``trackers:`` (in the file's order)."""
    return [BUILDERS[cfg.kind](name, cfg, scenario, world, rngs, rlog)
            for name, cfg in getattr(scenario, "trackers", {}).items()]
