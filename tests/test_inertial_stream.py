"""The inertial readings evaluated a block at a time equal the whole-run ones bit for bit."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from humimic.scenario import validate_scenario
from humimic.sensors import inertial_stream
from humimic.sensors.inertial import simulate_inertial, simulate_orientation
from humimic.sensors.inertial_stream import stream_inertial


def test_streamed_readings_equal_the_whole_run_draws(monkeypatch):
    """Blocks that do not divide the samples, read out of order and across block edges: every
    field equals simulate_inertial + simulate_orientation with the same seed (the same draws
    in the same order), and the generator ends where theirs does."""
    monkeypatch.setattr(inertial_stream, "BLOCK", 64)
    cfg = validate_scenario({"name": "s", "sensors": {"imu": {
        "accel_bias_walk": 0.02, "gyro_bias_walk": 0.003}}}).sensors.imu
    assert cfg.orientation
    n = 1000
    rng = np.random.default_rng(0)
    t = np.arange(n) / 180.0 + 0.01
    acc, gyr = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    R = Rotation.random(n, random_state=1).as_matrix()
    r_eager = np.random.default_rng(7)
    eager = simulate_inertial(t, acc, gyr, cfg, r_eager)
    o = simulate_orientation(t, R, cfg, r_eager)
    r_lazy = np.random.default_rng(7)
    lazy = stream_inertial(t, lambda i: (acc[i], gyr[i], R[i]), cfg, r_lazy, True)
    assert r_lazy.standard_normal() == r_eager.standard_normal()
    rows = np.r_[np.arange(900, 1000), np.arange(0, 130), [63, 64, 65, 500]]
    for name in ("accel", "gyro", "accel_true", "gyro_true", "accel_bias", "gyro_bias"):
        np.testing.assert_array_equal(getattr(lazy, name)[rows], getattr(eager, name)[rows],
                                      err_msg=name)
        np.testing.assert_array_equal(np.asarray(getattr(lazy, name)), getattr(eager, name))
    for name in ("R", "R_true", "errors"):
        np.testing.assert_array_equal(getattr(lazy.orientation, name)[rows],
                                      getattr(o, name)[rows], err_msg=name)
    np.testing.assert_array_equal(lazy.accel[437], eager.accel[437])
    assert np.abs(np.asarray(eager.accel_bias)[-1]).max() > 0  # the walk did walk
