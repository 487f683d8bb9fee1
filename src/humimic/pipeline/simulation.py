"""The simulation loop: physics at 840 Hz, sensors and stages at their own rates.

Per physics tick ``k`` (time ``t = k / physics_rate``):

1. write the person's state at ``t`` into the scene, ``mj_step1`` (kinematics at ``t``);
2. sample the sensors that are due (eye cameras, IMU, Wii remote) and publish them, minus the
   configured faults (:mod:`humimic.sensors.faults`);
3. deliver every bus value that is ready at ``t`` (stages run here, in causal order);
4. at servo ticks, let control stages write actuator targets, then step the planar base's
   controller (``world.base``) towards its target;
5. log poses to rerun at ``output.pose_rate``; ``mj_step2`` integrates to ``t + dt``;
6. every :data:`TRIM_EVERY_S` simulated seconds, give the C heap's free pages back
   (:func:`humimic.heap.trim_heap`: a long run's resident set otherwise creeps up).

A Ctrl-C stops the loop cleanly: the caller still gets the metrics so far. Every stage's
:meth:`~humimic.pipeline.stage.Stage.finish` runs when the loop ends.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np
from tqdm import tqdm

from humimic.heap import trim_heap
from humimic.messages import InertialReading
from humimic.pipeline.bus import Bus
from humimic.pipeline.stage import Stage, StageTimer
from humimic.sensors.clock import Schedule
from humimic.spill import SpillArray
from humimic.stamped import Stamped

#: Simulated seconds between :func:`~humimic.heap.trim_heap` calls in the loop.
TRIM_EVERY_S = 10.0


@dataclass
class SimResult:
    ticks_done: int
    sim_time_s: float
    wall_time_s: float
    interrupted: bool
    timer: StageTimer
    frames_published: int
    robot_qpos: SpillArray = field(repr=False)
    """(n_servo, 30) robot joint positions sampled at the servo rate (on disk: index it)."""
    servo_t: np.ndarray = field(repr=False)


def simulate(world, stages: list[Stage], rlog, bus: Bus | None = None,
             progress: bool = True) -> SimResult:
    scenario = world.scenario
    m, d = world.scene.model, world.scene.data
    phys_rate = scenario.timing.physics_rate
    servo_every = int(round(phys_rate / scenario.timing.servo_rate))
    bus = bus or Bus()
    timer = StageTimer()
    for stage in stages:
        stage.attach(bus, timer)

    cam_sched = (Schedule(scenario.cameras.rate, phys_rate)
                 if world.eye_rig is not None else None)
    head_sched = (Schedule(scenario.sensors.head_camera.rate, phys_rate)
                  if world.head_rig is not None else None)
    pose_sched = Schedule(min(scenario.output.pose_rate, phys_rate), phys_rate)
    inertial = []
    for topic, samples in (("imu", world.imu), ("wiimote", world.wiimote)):
        if samples is not None:
            data, ticks = samples
            keep = world.faults.keep(topic, len(ticks))  # samples kept, walked in tick order
            rows = np.flatnonzero(keep)
            inertial.append([topic, data, np.asarray(ticks)[rows], rows, 0])
    with timer.time("render_setup"):  # GL contexts before the clock starts
        for rig in (world.eye_rig, world.head_rig):
            if rig is not None:
                rig.prepare()
    latency = scenario.cameras.latency
    image_every = scenario.output.image_every
    quality = scenario.output.jpeg_quality

    n_servo = (world.n_ticks + servo_every - 1) // servo_every
    robot_qpos = SpillArray(n_servo, (len(world.scene.robot_qpos),))
    servo_t = np.zeros(n_servo)
    frames = head_frames = 0
    tick = 0
    interrupted = False
    # disable=None: tqdm draws only when stderr is a terminal (a log file gets no bar)
    bar = tqdm(total=round(scenario.duration, 3), unit="sim s",
               disable=None if progress else True,
               bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} sim s [{elapsed}<{remaining}]")
    update_every = max(1, int(phys_rate // 10))
    trim_every = max(1, round(TRIM_EVERY_S * phys_rate))
    wall0 = time.perf_counter()
    try:
        for tick in range(world.n_ticks):
            t = tick / phys_rate
            t0 = time.perf_counter()
            world.apply_human(tick)
            mujoco.mj_step1(m, d)
            t_phys = time.perf_counter() - t0

            if cam_sched is not None and cam_sched.due(tick):
                with timer.time("render"):
                    images = world.faults.frames.apply(t, world.eye_rig.capture(t))
                if world.visibility is not None and world.visibility.due(t):
                    with timer.time("visibility"):  # ground truth, whatever the faults
                        world.visibility.sample(t)
                if images is not None:
                    bus.publish("frames", Stamped(t, images, t + latency))
                    if image_every and frames % image_every == 0:
                        for name, img in images.items():
                            rlog.log_camera_image(t, f"world/cameras/{name}", img, quality)
                    frames += 1
            if head_sched is not None and head_sched.due(tick):
                with timer.time("render_headcam"):
                    image = world.capture_headcam(t)
                bus.publish("headcam", Stamped(t, image))
                if image_every and head_frames % image_every == 0:  # shown at its true pose
                    true = replace(image, camera=world.head_rig.camera_model("headcam"))
                    rlog.log_camera_image(t, "world/cameras/headcam", true, quality)
                head_frames += 1
            for sensor in inertial:  # [topic, samples, their ticks, their rows, next one]
                topic, data, ticks_kept, rows, j = sensor
                if j < len(rows) and ticks_kept[j] <= tick:
                    j = sensor[4] = int(np.searchsorted(ticks_kept, tick, side="right"))
                    if ticks_kept[j - 1] != tick:
                        continue
                    i = rows[j - 1]  # of samples sharing a tick (rate > physics), the last
                    R = data.orientation.R[i] if data.orientation is not None else None
                    bus.publish(topic, Stamped(t, InertialReading(data.accel[i], data.gyro[i],
                                                                  R)))

            bus.deliver(t)
            if tick % servo_every == 0:
                k = tick // servo_every
                robot_qpos[k] = d.qpos[world.scene.robot_qpos]
                servo_t[k] = t
                for stage in stages:
                    stage.servo(t, bus)
                if world.base is not None:  # after the stages: they may set its target
                    world.base.step(servo_every / phys_rate)
            if pose_sched.due(tick):
                with timer.time("viz"):
                    rlog.log_poses(t)

            t0 = time.perf_counter()
            mujoco.mj_step2(m, d)
            timer.add("physics", t_phys + time.perf_counter() - t0)
            if tick % update_every == 0:
                bar.n = round(t, 3)
                bar.refresh()
            if tick % trim_every == trim_every - 1:
                trim_heap()
        else:
            tick = world.n_ticks
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.n = round(tick / phys_rate, 3)
        bar.close()
    for stage in stages:
        stage.finish()
    wall = time.perf_counter() - wall0
    n_done = (tick + servo_every - 1) // servo_every
    return SimResult(tick, tick / phys_rate, wall, interrupted, timer, frames,
                     robot_qpos.truncate(n_done), servo_t[:n_done])
