"""The head pose at any instant: SLAM messages interpolated (against scipy's Slerp), held
beyond the last; the oracle's ground truth at the nearest tick."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from humimic.estimation.ekf.head_track import OracleHeadTrack, SlamHeadTrack
from humimic.messages import HeadPose


def _pose(p, R, w):
    q = np.roll(Rotation.from_matrix(R).as_quat(), 1)
    return HeadPose(np.asarray(p, float), q, np.zeros(3), np.asarray(w, float), np.zeros(3),
                    np.eye(19))


def test_slam_track_interpolates_like_slerp_and_holds():
    track = SlamHeadTrack()
    assert track.ready_until() == -np.inf
    rots = Rotation.random(3, random_state=1)
    times = [0.0, 1 / 30, 2 / 30]
    for k, t in enumerate(times):
        track.add(t, _pose([k, 0, 0], rots[k].as_matrix(), [k, 2 * k, 0]))
    assert track.ready_until() == times[-1]
    slerp = Slerp(times, rots)
    for t in (0.01, 1 / 30, 0.05):
        h = track.at(t)
        np.testing.assert_allclose(h.R_W_I, slerp([t]).as_matrix()[0], atol=1e-12)
        np.testing.assert_allclose(h.p_W, [30 * t, 0, 0], atol=1e-12)
        np.testing.assert_allclose(h.w_I, [30 * t, 60 * t, 0], atol=1e-12)
    np.testing.assert_allclose(track.at(1.0).p_W, [2, 0, 0])  # held after the last


class _Truth:
    t = np.arange(0, 101) / 100.0

    def pose(self, name, frame):
        T = np.tile(np.eye(4), (len(self.t), 1, 1))
        T[:, 0, 3] = self.t
        return T

    def angular_velocity(self, name, frame):
        return np.zeros((len(self.t), 3))


def test_oracle_track_reads_the_nearest_tick():
    track = OracleHeadTrack(_Truth())
    assert track.ready_until() == np.inf
    assert track.at(0.304).p_W[0] == 0.30
    assert track.at(0.306).p_W[0] == 0.31
    assert track.at(5.0).p_W[0] == 1.0 and track.at(-1.0).p_W[0] == 0.0
