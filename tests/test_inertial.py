"""The simulated IMU and Wii remote read the ground-truth motion plus their noise model:
white noise of the configured density and a bias random walk, seeded."""

from __future__ import annotations

import numpy as np
import pytest

from humimic.rngs import Rngs
from humimic.scenario import validate_scenario
from humimic.sensors.inertial import add_white_and_walk
from humimic.world.world import World


@pytest.fixture(scope="module")
def world():
    scenario = validate_scenario({
        "name": "imu", "duration": 3.0,
        "human": {"motion": {"kind": "head_sweep", "amplitude": 0.3, "period": 2.0}},
        "sensors": {"imu": {"rate": 200, "accel_bias_walk": 0.0, "gyro_bias_walk": 0.0}},
    })
    w = World(scenario, Rngs(3))
    yield w
    w.close()


def test_accelerometer_is_true_specific_force_plus_white_noise(world):
    samples, ticks = world.imu
    cfg = world.scenario.sensors.imu
    # independent truth: site acceleration minus gravity, rotated into the sensor frame
    R = world.gt.R_world("head_imu")[ticks]
    g = np.array([0.0, 0.0, -9.81])
    f_true = np.einsum("nji,nj->ni", R, world.gt.a_world("head_imu")[ticks] - g)
    err = samples.accel - f_true
    sigma = cfg.accel_noise_density * np.sqrt(cfg.rate)
    assert np.abs(err.mean(axis=0)).max() < 4 * sigma / np.sqrt(len(err))
    assert err.std(axis=0) == pytest.approx(np.full(3, sigma), rel=0.12)
    # and the head really moves sideways (the IMU's x is the interface frame's left): the
    # signal is far above the noise
    assert np.ptp(f_true[:, 0]) > 20 * sigma


def test_gyro_reads_the_angular_velocity(world):
    samples, ticks = world.imu
    err = samples.gyro - samples.gyro_true
    sigma = world.scenario.sensors.imu.gyro_noise_density * np.sqrt(200)
    assert err.std(axis=0) == pytest.approx(np.full(3, sigma), rel=0.12)


def test_imu_sample_times_follow_its_rate(world):
    samples, _ = world.imu
    assert len(samples.t) == pytest.approx(3.0 * 200, abs=1)
    assert np.diff(samples.t).mean() == pytest.approx(1 / 200, rel=1e-3)


def test_bias_random_walk_grows_like_sqrt_time():
    rng = np.random.default_rng(0)
    t = np.arange(0, 100.0, 0.01)
    walks = np.stack([add_white_and_walk(np.zeros((len(t), 3)), t, 0.0, 0.01, rng)[1]
                      for _ in range(200)])
    # Var[b(t)] = sigma_b^2 t
    var_end = walks[:, -1, :].var()
    assert var_end == pytest.approx(0.01**2 * t[-1], rel=0.15)


def test_same_seed_same_readings():
    scenario = validate_scenario({"name": "imu", "duration": 0.5})
    a, b = World(scenario, Rngs(5)), World(scenario, Rngs(5))
    try:
        assert np.array_equal(a.imu[0].accel, b.imu[0].accel)
        assert np.array_equal(a.wiimote[0].gyro, b.wiimote[0].gyro)
    finally:
        a.close()
        b.close()


def test_setting_one_wiimote_key_keeps_the_wiimote_defaults():
    """A regression: ``sensors.wiimote.drop_rate`` alone used to reset the remote to the head
    IMU's 180 Hz and noise densities."""
    base = validate_scenario({"name": "w"}).sensors.wiimote
    one = validate_scenario({"name": "w", "sensors": {"wiimote": {"drop_rate": 0.1}}})
    wii = one.sensors.wiimote
    assert wii.rate == base.rate == 100.0
    assert wii.drop_rate == 0.1
    assert wii.model_dump(exclude={"drop_rate"}) == base.model_dump(exclude={"drop_rate"})
