"""Record a wearable scenario's head-camera frames and IMU samples once, then run the SLAM
stage over them as often as wanted: timing the estimator without the renderer, comparing
settings on identical input (cycle times at 20 and 40 features, arm mask on and off).

    log = record(load_scenario("scenarios/sugiyama_table2.yaml"), duration=10)
    stage = replay(log, slam_config)          # a SlamStage that has seen every message
    stage.metrics()["slam"]["cycle_ms"]
"""

from __future__ import annotations

from dataclasses import dataclass, field

from humimic.pipeline.bus import Bus
from humimic.pipeline.stage import Stage, StageTimer
from humimic.rngs import Rngs


class _Recorder(Stage):
    name = "recorder"

    def __init__(self) -> None:
        self.messages: list[tuple[str, object]] = []

    def attach(self, bus, timer) -> None:
        for topic in ("headcam", "imu"):
            bus.subscribe(topic, lambda topic, msg: self.messages.append((topic, msg)))


@dataclass
class SensorLog:
    """A scenario's wearable sensor messages in delivery order, and its world (ground truth)."""

    scenario: object
    world: object
    messages: list[tuple[str, object]] = field(repr=False)

    @property
    def frames(self) -> int:
        return sum(topic == "headcam" for topic, _ in self.messages)


def record(scenario, duration: float | None = None, progress: bool = False) -> SensorLog:
    """Run ``scenario``'s world (no stages) for ``duration`` s and keep the head camera's and
    head IMU's messages (~265 kB per frame)."""
    from humimic.pipeline.simulation import simulate
    from humimic.viz.rerun_log import RerunLog
    from humimic.world.world import World

    if duration is not None:
        scenario = scenario.model_copy(update={"duration": duration})
    world = World(scenario, Rngs(scenario.seed))
    rec = _Recorder()
    try:
        with RerunLog(world.scene, "off", None, recording_id="record") as rlog:
            simulate(world, [rec], rlog, progress=progress)
    finally:
        world.close()
    return SensorLog(scenario, world, rec.messages)


def replay(log: SensorLog, cfg, seed: int | None = None):
    """A :class:`~humimic.estimation.ekf.slam_stage.SlamStage` configured by ``cfg`` (a
    ``slam`` section) that has processed every message of ``log`` in order."""
    from humimic.estimation.ekf.build import mask_params
    from humimic.estimation.ekf.slam_stage import SlamStage

    rngs = Rngs(log.scenario.seed if seed is None else seed)
    stage = SlamStage(cfg, log.world, rngs["slam"], None, mask_params(log.scenario))
    bus = Bus()
    stage.attach(bus, StageTimer())
    for topic, msg in log.messages:
        bus.publish(topic, msg)
        bus.deliver(msg.t)
    return stage
