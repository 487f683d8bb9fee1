"""Build the stages of the scenario's ``trackers:`` section, dispatching on each tracker's
``kind`` through :data:`BUILDERS` (one line per kind). A builder is ``(name, cfg, scenario,
world, rngs, rlog) -> list[Stage]``; kinds are imported only when a scenario uses them. A
stage with ``wire(stages) -> stages`` may then wrap the others (ICU's module switch gates its
near module)."""

from __future__ import annotations

from humimic.pipeline.stage import Stage


def _hand2d(name, cfg, scenario, world, rngs, rlog) -> list[Stage]:
    from humimic.perception.trackers.hand2d.build import hand2d_stage

    return [hand2d_stage(name, cfg, scenario, world, rngs, rlog)]


def _icu(name, cfg, scenario, world, rngs, rlog) -> list[Stage]:
    from humimic.perception.trackers.icu.build import icu_stage

    return [icu_stage(name, cfg, scenario, world, rngs, rlog)]


def _gest(name, cfg, scenario, world, rngs, rlog) -> list[Stage]:
    from humimic.perception.trackers.gest.build import gest_stage

    return [gest_stage(name, cfg, scenario, world, rngs, rlog)]


def _tbp(name, cfg, scenario, world, rngs, rlog) -> list[Stage]:
    from humimic.perception.trackers.tbp.build import tbp_stage

    return [tbp_stage(name, cfg, scenario, world, rngs, rlog)]


def _kpf(name, cfg, scenario, world, rngs, rlog) -> list[Stage]:
    from humimic.perception.trackers.kpf.build import kpf_stage

    return kpf_stage(name, cfg, scenario, world, rngs, rlog)


BUILDERS = {
    "hand2d": _hand2d,
    "icu": _icu,
    "gest": _gest,
    "tbp": _tbp,
    "kpf": _kpf,
}


def tracker_stages(scenario, world, rngs, rlog) -> list[Stage]:
    """The stages of every entry of ``trackers:`` (in the file's order)."""
    stages: list[Stage] = []
    for name, cfg in (getattr(scenario, "trackers", None) or {}).items():
        stages.extend(BUILDERS[cfg.kind](name, cfg, scenario, world, rngs, rlog))
    for st in list(stages):  # a tracker that gates others (ICU's Fig. 15 module switch)
        if hasattr(st, "wire"):
            stages = st.wire(stages)
    return stages
