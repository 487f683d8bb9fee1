"""Build the stages a scenario asks for, in pipeline order."""

from __future__ import annotations

from humimic.pipeline.stage import Stage


def build_stages(scenario, world, rngs, rlog) -> list[Stage]:
    """One stage per optional scenario section that is present (perception, filter, mimic),
    after the wearable probe when the head camera is on."""
    stages: list[Stage] = []
    if scenario.sensors.head_camera.enabled:  # what the wearable sensors see (wearable.*)
        from humimic.world.wearable_probe import WearableProbe

        stages.append(WearableProbe(world))
    if (getattr(scenario, "perception", None) is not None
            or getattr(scenario, "filter", None) is not None):
        from humimic.perception.blobs.build import perception_stages

        stages.extend(perception_stages(scenario, world, rngs, rlog))
    if getattr(scenario, "mimic", None) is not None:
        from humimic.control.build import mimic_stages

        stages.extend(mimic_stages(scenario, world, rngs, rlog))
    return stages
