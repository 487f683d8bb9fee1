"""Sensor faults (lost, frozen and covered frames, lost inertial samples): the injector on
synthetic frames, then whole runs in which the filter coasts through them and tracking resumes.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from humimic.paths import SCENARIOS_DIR
from humimic.pipeline.build import build_stages
from humimic.pipeline.simulation import simulate
from humimic.pipeline.stage import Stage
from humimic.rngs import Rngs
from humimic.scenario import ScenarioError, load_scenario
from humimic.sensors.camera_model import CameraImage
from humimic.sensors.faults import FrameFaults, keep_samples
from humimic.viz.rerun_log import RerunLog
from humimic.world.world import World

CAMS = ["L_wide", "R_wide"]
RATE = 60.0


def _frames(n: int):
    """``n`` stereo frame sets of tiny images, every image unique (its frame index in it)."""
    for k in range(n):
        t = k / RATE
        yield t, {c: CameraImage(t, None, np.full((4, 6, 3), (k + 7 * i) % 256, np.uint8))
                  for i, c in enumerate(CAMS)}


def _run(faults: FrameFaults, n: int):
    return [(t, faults.apply(t, images), images) for t, images in _frames(n)]


def _binomial_ok(count: int, n: int, p: float) -> bool:
    return abs(count - n * p) <= 4.0 * np.sqrt(n * p * (1 - p))


def test_dropped_frames_are_lost_whole_at_the_rate():
    f = FrameFaults(CAMS, drop_rate=0.2, rng=np.random.default_rng(1))
    out = _run(f, 3000)
    lost = [t for t, o, _ in out if o is None]
    assert len(lost) == f.dropped and _binomial_ok(f.dropped, 3000, 0.2)
    delivered = [o for _, o, _ in out if o is not None]
    assert all(set(o) == set(CAMS) for o in delivered)
    again = FrameFaults(CAMS, drop_rate=0.2, rng=np.random.default_rng(1))
    assert [t for t, o, _ in _run(again, 3000) if o is None] == lost  # same seed, same losses


def test_a_frozen_camera_repeats_its_last_delivered_image_under_the_new_time():
    f = FrameFaults(CAMS, drop_rate=0.2, freeze_rate=0.1, rng=np.random.default_rng(2))
    out = _run(f, 2000)
    prev: dict[str, np.ndarray] = {}
    frozen = dict.fromkeys(CAMS, 0)
    for t, o, fresh in out:
        if o is None:
            continue
        for c in CAMS:
            st = f.status(t, c)
            if st is not None and st.frozen:
                frozen[c] += 1
                assert np.array_equal(o[c].image, prev[c]) and o[c].t == t
                assert st.t_content < t
            else:
                assert o[c].image is fresh[c].image
            prev[c] = o[c].image
    assert frozen == f.frozen
    assert all(_binomial_ok(v, 2000 - f.dropped, 0.1) for v in frozen.values())
    assert f.status(0.0, "L_wide") is None  # the first frame has nothing to repeat


def test_a_covered_camera_is_black_in_its_window_only():
    f = FrameFaults(CAMS, covered={"L_wide": [(0.5, 1.0)]})
    for t, o, fresh in _run(f, 120):
        if 0.5 <= t < 1.0:
            assert not o["L_wide"].image.any() and f.status(t, "L_wide").covered
        else:
            assert o["L_wide"].image is fresh["L_wide"].image
        assert o["R_wide"].image is fresh["R_wide"].image
    assert f.blacked == {"L_wide": 30, "R_wide": 0} and f.dropped == 0


def test_a_covered_noisy_camera_shows_its_dark_noise():
    f = FrameFaults(CAMS, covered={"L_wide": [(0.0, 1.0)]}, noise_std=2.0,
                    dark_rng=np.random.default_rng(6))
    dark = [o["L_wide"].image for _, o, _ in _run(f, 10)]
    assert all(0.3 < d.mean() < 1.5 and d.max() <= 12 for d in dark)  # half-normal: 0.8
    assert not any(np.array_equal(a, b) for a, b in zip(dark[:-1], dark[1:], strict=True))


def test_one_fault_rate_does_not_shift_another_faults_pattern():
    def faults(drop):
        f = FrameFaults(CAMS, drop_rate=drop, freeze_rate=0.1, rng=np.random.default_rng(5))
        _run(f, 500)
        return set(f.faulted), set(f.lost)
    frozen, _ = faults(0.0)
    frozen_with_losses, lost = faults(0.3)
    assert len(lost) > 100 and frozen_with_losses == frozen - lost


def test_inertial_dropouts_at_the_rate():
    keep = keep_samples(5000, 0.05, np.random.default_rng(4))
    assert _binomial_ok(int((~keep).sum()), 5000, 0.05)
    assert keep_samples(10, 0.0, None).all()


def test_a_covered_camera_the_scenario_lacks_is_a_scenario_error():
    sc = load_scenario(SCENARIOS_DIR / "static.yaml",
                       ["cameras.eyes=left", "cameras.covered=[{camera: right, start: 0, end: 1}]"])
    with pytest.raises(ScenarioError, match="cameras.covered.0.camera"):
        World(sc, Rngs(0))


# ---- whole runs ---------------------------------------------------------------------------------
class Counter(Stage):
    """Counts what arrives on the sensor topics."""

    name = "counter"

    def __init__(self):
        self.n = {"frames": 0, "imu": 0, "wiimote": 0}

    def attach(self, bus, timer) -> None:
        for topic in self.n:
            bus.subscribe(topic, self._count)

    def _count(self, topic, msg) -> None:
        self.n[topic] += 1


def _simulate(name: str, overrides: list[str], duration: float, extra=()):
    sc = load_scenario(SCENARIOS_DIR / f"{name}.yaml",
                       ['output.rerun="off"', "output.plots=false", *overrides],
                       duration=duration)
    rngs = Rngs(sc.seed)
    world = World(sc, rngs)
    rlog = RerunLog(world.scene, "off", None, "test")
    counter = Counter()
    stages = [*build_stages(sc, world, rngs, rlog), counter, *extra]
    try:
        simulate(world, stages, rlog, progress=False)
        metrics = world.faults.metrics()
        for stage in stages:
            metrics.update(stage.metrics())
    finally:
        for stage in stages:
            stage.close()
        world.close()
    json.dumps(metrics, allow_nan=False)  # never a NaN
    return metrics, {s.name: s for s in stages}, counter.n, world


@pytest.mark.slow
def test_inertial_samples_are_lost_at_their_rates():
    m, _, n, _ = _simulate("static", ["sensors.imu.drop_rate=0.1", "sensors.wiimote.drop_rate=0.3",
                                   "sensors.wiimote.rate=100", "cameras.resolution=[32, 24]"],
                        2.0)
    f = m["faults"]
    assert f["imu_samples"] == 360 and f["wiimote_samples"] == 200  # 180 Hz, 100 Hz
    assert n["imu"] == 360 - f["imu_samples_dropped"]
    assert n["wiimote"] == 200 - f["wiimote_samples_dropped"]
    assert _binomial_ok(f["imu_samples_dropped"], 360, 0.1)
    assert _binomial_ok(f["wiimote_samples_dropped"], 200, 0.3)
    assert n["frames"] == f["frames"] == 120 and f["frames_dropped"] == 0


class Listener(Stage):
    """Records every measurements and estimates message (topic, photon time, ready time,
    positions)."""

    name = "listener"

    def __init__(self):
        self.got = []

    def attach(self, bus, timer) -> None:
        for topic in ("measurements", "estimates"):
            bus.subscribe(topic, self._on)

    def _on(self, topic, msg) -> None:
        self.got.append((topic, msg.t, msg.t_ready, {k: np.asarray(v.p_base).tolist()
                                                     for k, v in msg.value.targets.items()}))


def _tracked(overrides: list[str], duration: float):
    """ude_wave_tracking (wide 320x240, pixel noise 2) with detection from the first frame."""
    listener = Listener()
    m, stages, _, world = _simulate("ude_wave_tracking", ["perception.detection.period=0.0",
                                                          *overrides], duration, extra=[listener])
    return m, stages, listener.got, world


@pytest.mark.slow
def test_the_filter_coasts_through_a_covered_camera_and_tracking_resumes():
    m, stages, _, _ = _tracked(["cameras.covered=[{camera: left, start: 1.2, end: 1.8}]"], 3.0)
    assert m["faults"]["frames_covered"] == {"L_wide": 36, "R_wide": 0}
    f = stages["filter"]
    a, gt = f.record.arrays(), f.gt
    i = a.targets.index("right_hand")
    meas, valid = a.measured[:, i], a.valid[:, i]
    covered = (a.t >= 1.2 - 1e-9) & (a.t < 1.8 - 1e-9)
    assert not meas[covered].any() and meas[a.t < 1.2].sum() >= 40
    # coasting: prediction only, the position variance growing frame by frame, until the
    # filter gives the target up after max_gap (0.2 s) and is reset
    coast = covered & valid
    var = np.trace(a.P[:, i, :3, :3], axis1=1, axis2=2)
    assert 10 <= coast.sum() <= 13 and np.all(np.diff(var[coast]) > 0)
    last_measured = np.flatnonzero(meas & (a.t < 1.2))[-1]
    assert var[coast][-1] >= 5.0 * var[last_measured]
    assert m["filter"]["resets"]["right_hand"] == 1
    assert m["filter"]["coasted_frames"]["right_hand"] == coast.sum()
    # tracking resumes once the camera is uncovered, and is accurate again
    t_back = a.t[meas & (a.t >= 1.8)][0]
    assert t_back <= 2.2  # measured: 1.90 s
    late = valid & (a.t >= t_back + 0.3)
    err = np.linalg.norm(a.x[late, i, :3] - gt.p_base("right_hand")[
        [gt.index_of(t) for t in a.t[late]]], axis=1)
    assert late.sum() >= 20 and np.sqrt(np.mean(err**2)) <= 0.015  # measured: 6.5 mm
    assert m["filter"]["nonfinite_estimates"] == 0


@pytest.mark.slow
def test_lost_and_frozen_frames_are_skipped_and_pipelining_changes_nothing():
    faults = ["cameras.drop_rate=0.2", "cameras.freeze_rate=0.1"]
    m, stages, got, world = _tracked([*faults, "perception.pipelined=thread"], 2.5)
    sync, _, got_sync, _ = _tracked([*faults, "perception.pipelined=off"], 2.5)
    assert got == got_sync and m["tracking"] == sync["tracking"]
    f, p = m["faults"], m["perception"]
    frozen = sum(f["frames_frozen"].values())
    assert _binomial_ok(f["frames_dropped"], f["frames"], 0.2)
    assert _binomial_ok(frozen, 2 * f["frames"], 0.1)
    # every delivered frame set with a frozen image is seen as stale and skipped
    assert p["stale_frames_skipped"] == len(world.faults.frames.faulted) > 0
    assert p["frames"] == f["frames"] - f["frames_dropped"] - p["stale_frames_skipped"]
    hand = m["tracking"]["right_hand"]
    assert hand["filtered_rmse_mm"] <= 15.0  # measured: 6.3 mm (7.4 mm without faults)
    assert m["filter"]["nonfinite_estimates"] == 0


@pytest.mark.slow
def test_the_oracle_sees_what_the_faulty_cameras_show():
    """Oracle perception gets no estimate from a lost frame or a covered camera, and a stale one
    (the truth at the repeated image's capture time) from a frozen camera."""
    m, stages, _, world = _simulate("mimic_wave", [
        "cameras.resolution=[80, 60]", "cameras.drop_rate=0.1", "cameras.freeze_rate=0.1",
        "cameras.covered=[{camera: right, start: 0.5, end: 1.0}]"], 2.0)
    o, f = m["oracle"], m["faults"]
    faulted = world.faults.frames.faulted.values()
    assert o["frames"] == f["frames"] - f["frames_dropped"]
    assert o["blind_frames"] == f["frames_covered"]["R_wide"] > 20
    assert o["stale_frames"] == sum(not any(s.covered for s in st.values()) for st in faulted) > 5
    palm = m["mimicry"]["R_palm"]
    assert palm["status"] == "ok" and palm["lost_fraction"] > 0.05  # held while blind
    assert m["mimicry"]["joints"]["finite"]
