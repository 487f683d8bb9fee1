"""Cartesian PD interpolation (Ude & Atkeson) against closed forms and scipy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from humimic.control.interpolation import (
    CartesianInterpolator,
    pd_discretize,
    pd_gains,
    pd_step,
    reference,
)

DT = 1.0 / 420.0


def test_step_response_is_critically_damped():
    """Reference at rest at 1: p(t) = 1 - (1 + w t) exp(-w t) (closed form)."""
    w = 20.0
    kp, kd = pd_gains(w, 1.0)
    p, v = np.zeros(3), np.zeros(3)
    one, zero = np.ones(3), np.zeros(3)
    t = np.arange(1, 421) * DT
    out = []
    for _ in t:
        p, v, _ = pd_step(p, v, one, zero, zero, kp, kd, *pd_discretize(kp, kd, DT))
        out.append(p[0])
    exact = 1.0 - (1.0 + w * t) * np.exp(-w * t)
    assert np.max(np.abs(np.array(out) - exact)) < 1e-12


def test_feedforward_tracks_a_smooth_reference_without_lag():
    """With the reference's own v and a fed forward, the error obeys e'' + kd e' + kp e = 0:
    started on the reference, the command stays on it (to integration error)."""
    w_ref = 2 * np.pi * 0.5
    kp, kd = pd_gains(20.0, 1.0)
    disc = pd_discretize(kp, kd, DT)
    p, v = np.zeros(3), np.array([0.2 * w_ref, 0.0, 0.0])
    err = []
    for k in range(1, 841):
        t = (k - 0.5) * DT  # the reference held over a step is its mid-step value
        p_r = np.array([0.2 * np.sin(w_ref * t), 0, 0])
        v_r = np.array([0.2 * w_ref * np.cos(w_ref * t), 0, 0])
        a_r = np.array([-0.2 * w_ref**2 * np.sin(w_ref * t), 0, 0])
        p, v, _ = pd_step(p, v, p_r, v_r, a_r, kp, kd, *disc)
        err.append(p[0] - 0.2 * np.sin(w_ref * k * DT))
    assert np.max(np.abs(err)) < 6e-6  # measured 2.1 um (the bound was 0.2 mm)


def test_pd_matches_scipy_on_a_held_ramp_reference():
    """Hold mode between two frames: constant (p, v, a) reference; compare with solve_ivp."""
    kp, kd = pd_gains(20.0, 1.0)
    p_r, v_r, a_r = 0.05, 0.3, -1.0

    def f(_t, y):
        return [y[1], a_r + kd * (v_r - y[1]) + kp * (p_r - y[0])]

    sol = solve_ivp(f, (0, 0.1), [0.0, 0.0], rtol=1e-10, atol=1e-12, dense_output=True)
    p, v = np.zeros(3), np.zeros(3)
    n = int(round(0.1 / DT))
    for _ in range(n):
        p, v, _ = pd_step(p, v, np.full(3, p_r), np.full(3, v_r), np.full(3, a_r), kp, kd,
                          *pd_discretize(kp, kd, DT))
    assert p[0] == pytest.approx(sol.sol(n * DT)[0], abs=1e-8)
    assert v[0] == pytest.approx(sol.sol(n * DT)[1], abs=1e-7)


def test_reference_modes_and_staleness():
    p, v, a = np.array([1.0, 0, 0]), np.array([0.0, 1.0, 0]), np.array([0, 0, 2.0])
    hold = reference(p, v, a, 0.01, "hold", 0.25)
    assert all(np.array_equal(x, y) for x, y in zip(hold, (p, v, a), strict=True))
    ext = reference(p, v, a, 0.01, "extrapolate", 0.25)
    np.testing.assert_allclose(ext[0], [1.0, 0.01, 1e-4])
    stale = reference(p, v, a, 1.0, "hold", 0.25)
    np.testing.assert_array_equal(stale[0], p)
    assert not stale[1].any() and not stale[2].any()


def test_interpolator_starts_on_the_reference():
    ip = CartesianInterpolator(20.0, 1.0, DT, "extrapolate")
    p, v, a = np.zeros(3), np.array([1.0, 0, 0]), np.zeros(3)
    ip.start(p, v, a, age=0.01)
    np.testing.assert_allclose(ip.p, [0.01, 0, 0])
    out = ip.step(p, v, a, age=0.01)  # on the reference: moves with it at 1 m/s
    np.testing.assert_allclose(out, [0.01 + DT, 0, 0], atol=1e-6)
    assert abs(out[0] - (0.01 + DT)) < 1e-3 * DT
