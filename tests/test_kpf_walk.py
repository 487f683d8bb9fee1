"""The arms' propagation noise shaped by the image Jacobian
(:func:`~humimic.perception.trackers.kpf.velocity.noise_shaping`, ``KpfConfig.observed_walk_px``):
the shaping matrix against the normal equations solved directly and a hand-built Jacobian's
singular directions, the shaped propagation's sample covariance against the closed form."""

from __future__ import annotations

import numpy as np
from _kpf_synth import INTRINSICS, camera, static_pose

from humimic.estimation.particles import kernel as kpf
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.perception.trackers.kpf.velocity import arm_noise_shaping, noise_shaping


def test_noise_shaping_is_floor_plus_the_damped_projection():
    """``floor I + (1 - floor) (J^T J + lam^2 I)^-1 J^T J`` by a linear solve (no SVD)."""
    rng = np.random.default_rng(11)
    for m, d in ((4, 4), (2, 4), (6, 3)):
        J = rng.normal(size=(m, d)) * 30.0
        for lam, floor in ((1.0, 0.25), (10.0, 0.5), (50.0, 0.0)):
            P = np.linalg.solve(J.T @ J + lam * lam * np.eye(d), J.T @ J)
            assert np.allclose(noise_shaping(J, lam, floor),
                               floor * np.eye(d) + (1 - floor) * P, atol=1e-12)
        assert np.allclose(noise_shaping(J, 10.0, 1.0), np.eye(d))


def test_a_hand_built_jacobian_keeps_the_seen_directions_and_floors_the_unseen():
    """``J = U diag(40, 30, 20, 0) V^T`` from random orthonormal U, V: A's eigenvectors are V's
    columns, its eigenvalues ``floor + (1 - floor) s^2 / (s^2 + lam^2)``; the zero singular
    value's direction keeps exactly ``floor``; with lam -> 0 every seen direction keeps 1."""
    rng = np.random.default_rng(2)
    U, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    V, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    s = np.array([40.0, 30.0, 20.0, 0.0])
    J = U @ np.diag(s) @ V.T
    A = noise_shaping(J, 10.0, 0.25)
    assert np.allclose(A, A.T)
    for k in range(4):
        want = 0.25 + 0.75 * s[k] ** 2 / (s[k] ** 2 + 100.0)
        assert np.allclose(A @ V[:, k], want * V[:, k], atol=1e-12)
    A0 = noise_shaping(J, 1e-9, 0.25)
    assert np.allclose(A0 @ V[:, :3], V[:, :3]) and np.allclose(A0 @ V[:, 3], 0.25 * V[:, 3])


def test_shaped_propagation_has_the_closed_form_covariance():
    """Random-walk noise ``A n`` with ``n`` uniform of half-width D: covariance
    ``A diag(D^2 / 3) A^T`` (sample covariance of 200k draws: measured <= 0.41 % of the largest
    entry off over seeds 10-15, 0.17 % on this one; 2026-11-29); the motion group's
    the same with ``motion_scale D``; without ``shape`` the paper's diagonal."""
    rng = np.random.default_rng(4)
    d, n = 4, 200_000
    D = np.array([0.4, 0.35, 0.6, 0.45])
    A = noise_shaping(rng.normal(size=(3, d)) * 20.0, 10.0, 0.25)
    x = np.zeros((n, d))
    for share, scale in ((0.0, 1.0), (1.0, 0.25)):
        out, _ = kpf.mixed_propagate(x, np.zeros(d), share, D, rng, lambda q: np.ones(len(q),
                                     bool), 0.25, shape=A)
        want = A @ np.diag((scale * D) ** 2 / 3.0) @ A.T
        assert np.abs(np.cov(out.T) - want).max() < 0.01 * np.abs(want).max()  # was 0.02
    out, _ = kpf.mixed_propagate(x, np.zeros(d), 0.0, D, rng, lambda q: np.ones(len(q), bool))
    # measured <= 0.11 % of D_max^2 over seeds 10-15 (the bound was 2 %)
    assert np.allclose(np.cov(out.T), np.diag(D ** 2 / 3.0), atol=0.003 * D.max() ** 2)


def test_shaping_one_group_only_leaves_the_others_noise_diagonal():
    """``shape_groups="random"`` (``observed_walk_groups``): the random group's covariance
    ``A diag(D^2 / 3) A^T``, the motion group's the paper's ``diag((0.25 D)^2 / 3)``
    (sample covariances of 200k draws each: measured <= 0.48 % of the largest entry off over
    seeds 10-15; 2026-11-29); ``"motion"`` the other way round."""
    rng = np.random.default_rng(6)
    d, n = 4, 400_000
    D = np.array([0.4, 0.35, 0.6, 0.45])
    A = noise_shaping(rng.normal(size=(3, d)) * 20.0, 10.0, 0.25)
    walk, motion = np.diag(D ** 2 / 3.0), np.diag((0.25 * D) ** 2 / 3.0)
    for groups, want_r, want_m in (("random", A @ walk @ A.T, motion),
                                   ("motion", walk, A @ motion @ A.T)):
        out, moved = kpf.mixed_propagate(np.zeros((n, d)), np.zeros(d), 0.5, D, rng,
                                         lambda q: np.ones(len(q), bool), 0.25, shape=A,
                                         shape_groups=groups)
        assert np.abs(np.cov(out[~moved].T) - want_r).max() < 0.01 * np.abs(want_r).max()
        assert np.abs(np.cov(out[moved].T) - want_m).max() < 0.01 * np.abs(want_m).max()


def test_a_straight_arms_twist_noise_is_floored_and_the_torso_untouched():
    """The tracker's use: a straight arm's humeral rotation moves no pixel, so its noise keeps
    the floor; the torso's block is the identity."""
    body, T = kpf_body(), camera()
    q = static_pose()
    q[9] = q[13] = 0.0
    A = arm_noise_shaping(body, INTRINSICS, q, T, 10.0, 0.25)
    assert np.allclose(A[:6], np.eye(14)[:6]) and np.allclose(A[:, :6], np.eye(14)[:, :6])
    for hr in (8, 12):
        e = np.eye(14)[hr]
        assert np.allclose(A @ e, 0.25 * e, atol=1e-4)
