"""Build the scenario's ``trackers:`` stages, dispatching on each tracker's ``kind`` through
:data:`BUILDERS` (one line per kind). A builder is ``(name, cfg, scenario, world, rngs, rlog)
-> list[Stage]``."""

from __future__ import annotations

from humimic.perception.trackers.kpf.build import kpf_stage

BUILDERS = {
    "kpf": kpf_stage,
}


def tracker_stages(scenario, world, rngs, rlog) -> list:
    stages = []
    for name, cfg in (getattr(scenario, "trackers", None) or {}).items():
        stages.extend(BUILDERS[cfg.kind](name, cfg, scenario, world, rngs, rlog))
    return stages
