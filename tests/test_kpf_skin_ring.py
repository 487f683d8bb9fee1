"""The kpf's skin-surround cue (:mod:`humimic.perception.trackers.kpf.skin_ring`) against
closed forms: the ring's points on the scaled ellipse, its skin fraction on a drawn skin disc
(all skin inside the disc's radius, none outside, the arc fraction in between)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from humimic.perception.trackers.kpf import skin_ring as R
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.cues import CueMaps


def skin_maps(h: int, w: int, centre, radius: int) -> CueMaps:
    skin = np.zeros((h, w), np.float32)
    cv2.circle(skin, centre, radius, 1.0, -1)
    z = np.zeros((1, 1), np.float32)
    return CueMaps(z, z, np.zeros((1, 2)), np.zeros(1), z, skin)


def test_ring_points_lie_on_the_scaled_rotated_ellipse():
    centre = np.array([[[50.0, 40.0]]])
    axes = np.array([[[6.0, 3.0]]])
    angle = np.array([[0.7]])
    p = R.ring_points(centre, axes, angle, 1.5)[0, 0] - centre[0, 0]
    c, s = np.cos(0.7), np.sin(0.7)
    x, y = (p @ np.array([[c, -s], [s, c]])).T      # into the ellipse's own axes
    assert np.allclose((x / 9.0) ** 2 + (y / 4.5) ** 2, 1.0)
    assert p.shape == (R.RING_POINTS, 2)


def test_ring_skin_on_a_disc():
    maps = skin_maps(100, 120, (60, 50), 10)
    centre, axes, angle = np.array([[[60.0, 50.0]]]), np.array([[[5.0, 5.0]]]), np.zeros((1, 1))
    assert R.ring_skin(maps, centre, axes, angle, 1.5)[0, 0] == 1.0     # ring radius 7.5
    assert R.ring_skin(maps, centre, axes, angle, 2.6)[0, 0] == 0.0     # 13
    # a ring of radius 10 centred 10 px below the disc's centre: its points within the disc
    # (by their distance to its centre, an independent count of the raster's pixels)
    pts = R.ring_points(np.array([[[60.0, 60.0]]]), np.array([[[5.0, 5.0]]]), angle, 2.0)
    want = np.mean(np.linalg.norm(np.rint(pts[0, 0]) - [60, 50], axis=1) <= 10.0)
    assert 0.0 < want < 1.0
    part = R.ring_skin(maps, np.array([[[60.0, 60.0]]]), np.array([[[5.0, 5.0]]]), angle, 2.0)
    assert part[0, 0] == pytest.approx(want, abs=1.0 / R.RING_POINTS)


def test_ring_log_term_is_eq9s_gaussian():
    s = np.array([0.0, 0.5, 1.0])
    assert np.allclose(R.ring_log_term(s, 0.4), np.log(np.exp(-s ** 2 / 0.32)))


def test_config_checks_the_ring_scale():
    assert KpfConfig().skin_ring is None
    assert KpfConfig(skin_ring=1.5).skin_ring == 1.5
    with pytest.raises(ValueError, match="skin_ring"):
        KpfConfig(skin_ring=0.8)
