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
    if getattr(scenario, "trackers", None):  # Menezes' and Schmidt's trackers (poses, tracks2d)
        from humimic.perception.trackers.build import tracker_stages

        stages.extend(tracker_stages(scenario, world, rngs, rlog))
    if getattr(scenario, "slam", None) is not None:  # the wearable's head pose (Sugiyama)
        from humimic.estimation.ekf.build import slam_stages

        stages.extend(slam_stages(scenario, world, rngs, rlog))
    if getattr(scenario, "arm", None) is not None:
        from humimic.estimation.ekf.arm_config import check_arm
        from humimic.estimation.ekf.arm_stage import ArmStage

        check_arm(scenario)
        stages.append(ArmStage(world, scenario.arm, rlog))
    if getattr(scenario, "commands", None) is not None:
        from humimic.control.build import commands_stages

        stages.extend(commands_stages(scenario, world, rngs, rlog))
    if getattr(scenario, "mimic", None) is not None:
        from humimic.control.build import mimic_stages

        stages.extend(mimic_stages(scenario, world, rngs, rlog))
    return stages
