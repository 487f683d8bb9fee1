"""The motion model's velocity restricted to what the image sees
(:mod:`humimic.perception.trackers.kpf.velocity`, ``KpfConfig.observed_velocity_px``): the
damped projection against the normal equations solved directly, the image Jacobian against
the kinematics' closed-form zeros and a finite step's image motion."""

from __future__ import annotations

import numpy as np
from _kpf_synth import INTRINSICS, camera, static_pose

from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.perception.trackers.kpf.velocity import (
    arm_image_jacobian,
    observable_arm_velocity,
    observable_velocity,
    particle_velocities,
)


def test_observable_velocity_is_the_damped_least_squares_projection():
    """``(J^T J + lam^2 I)^-1 J^T J v`` by a linear solve (no SVD), for random and rank-
    deficient Jacobians; lam -> 0 gives the orthogonal projection onto J's row space
    (``pinv(J) J v``), a large lam keeps nothing."""
    rng = np.random.default_rng(3)
    for m, d in ((4, 4), (2, 4), (6, 3)):
        J = rng.normal(size=(m, d)) * 30.0
        v = rng.normal(size=d)
        for lam in (1.0, 10.0, 50.0):
            want = np.linalg.solve(J.T @ J + lam * lam * np.eye(d), J.T @ J @ v)
            assert np.allclose(observable_velocity(v, J, lam), want, atol=1e-12)
        assert np.allclose(observable_velocity(v, J, 1e-9), np.linalg.pinv(J) @ J @ v,
                           atol=1e-9)
        assert np.linalg.norm(observable_velocity(v, J, 1e9)) < 1e-9
        rows = rng.normal(size=(5, d))                 # one velocity per particle: row-wise
        assert np.allclose(observable_velocity(rows, J, 10.0),
                           [observable_velocity(r, J, 10.0) for r in rows])
    # a DOF that moves no pixel (zero column) loses its velocity, the others keep theirs
    J = np.diag([40.0, 40.0, 0.0, 40.0])
    out = observable_velocity(np.ones(4), J, 1e-6)
    assert np.allclose(out, [1.0, 1.0, 0.0, 1.0])


def test_arm_image_jacobian_zeros_and_a_small_step():
    """Closed forms: the elbow does not move with the elbow flexion (EB column, elbow rows);
    a straight arm's humeral rotation moves neither elbow nor wrist (HR column). And J dq
    predicts the image motion of a small step dq off the axes."""
    body, T = kpf_body(), camera()
    q = static_pose()
    J = arm_image_jacobian(body, INTRINSICS, q, "R", T)
    assert J.shape == (4, 4)
    assert np.abs(J[:2, 3]).max() < 1e-12  # measured 0 (was 1e-6)
    assert np.abs(J).max() > 20.0    # f l / z: 260 px x 0.3 m / 2.2 m ~ 35 px/rad at the elbow
    straight = q.copy()
    straight[9] = 0.0
    Js = arm_image_jacobian(body, INTRINSICS, straight, "R", T)
    assert np.abs(Js[:, 2]).max() < 1e-12  # measured 0 (was 1e-5)
    dq = np.array([0.4, -0.3, 0.2, 0.5]) * 1e-3
    q2 = q.copy()
    q2[6:10] += dq
    p = [body.forward(x[None]) for x in (q, q2)]
    uv = [np.concatenate([INTRINSICS.project(pp.joint(f"r_{j}") @ T[:3, :3].T + T[:3, 3])[0]
                          for j in ("elbow", "wrist")]) for pp in p]
    assert np.allclose(J @ dq, uv[1] - uv[0], atol=4e-5)  # second order: measured 1.2e-5 px


def test_a_straight_arms_humeral_rotation_velocity_is_dropped():
    """The tracker's use: on a straight arm the velocity along HR (no image motion) goes, the
    torso's and the image-moving DOFs' are kept (within the damping's s^2/(s^2+lam^2))."""
    body, T = kpf_body(), camera()
    q = static_pose()
    q[9] = q[13] = 0.0
    v = np.full(14, 0.05)
    out = observable_arm_velocity(body, INTRINSICS, q, v, T, 1.0)
    assert np.allclose(out[:6], v[:6])
    assert abs(out[8]) < 1e-12 and abs(out[12]) < 1e-12        # R_HR, L_HR: measured 0
    # measured 5.8e-4 (2026-11-29; the bound was 5e-3)
    assert np.allclose(out[[6, 7, 9]], v[[6, 7, 9]], atol=1.5e-3)


def test_per_particle_velocities_follow_their_particles_through_partitioned_resampling():
    """``KpfConfig.particle_velocity``'s carrying: the indices drawn per group pick each group's
    columns from one ancestor, the same ancestor for the particles and anything carried with
    them; a group whose weight sits on one particle takes only that one; and drawing the
    indices uses the generator as :func:`partitioned_resample` does (same particles)."""
    from humimic.estimation.particles import kernel as kpf
    from humimic.estimation.particles.resampling import resample_indices

    rng = np.random.default_rng(5)
    n, groups = 50, [np.arange(0, 2), np.arange(2, 5)]
    x = rng.normal(size=(n, 5))
    vel = 3.0 * x + 1.0                                   # a per-particle quantity
    W = rng.random((n, 2))
    W /= W.sum(0)
    W[:, 1] = 0.0
    W[17, 1] = 1.0
    idx = kpf.partitioned_resample_indices(W, groups, np.random.default_rng(9))
    xs, vs = kpf.partitioned_take(x, idx, groups), kpf.partitioned_take(vel, idx, groups)
    assert np.allclose(vs, 3.0 * xs + 1.0)
    assert np.all(xs[:, 2:] == x[17, 2:])
    # the resampling as it was written before the split (group by group, one systematic draw
    # each from the same generator): the same particles, so the default path's draws stand
    ref, r = np.empty_like(x), np.random.default_rng(9)
    for k, g in enumerate(groups):
        ref[:, g] = x[resample_indices(np.log(np.maximum(W[:, k], 1e-300)), r)][:, g]
    assert np.array_equal(xs, ref)
    assert np.array_equal(kpf.partitioned_resample(x, W, groups, np.random.default_rng(9)), ref)


def test_tracker_per_particle_velocities_skip_jumps_and_lost_frames():
    """In the tracker (``particle_velocity``, with ``observed_velocity_px``): a particle a flip
    jump moved carries no velocity (a jump is no motion to repeat: with every particle offered
    a flip most rows are zero, without jumps none), and a lost frame leaves none at all."""
    from _kpf_synth import INTRINSICS, camera, painted_person, static_pose

    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model
    from humimic.perception.trackers.kpf.config import KpfConfig
    from humimic.perception.trackers.kpf.frame_cues import FrameCues
    from humimic.perception.trackers.kpf.tracker import KpfTracker, kpf_body

    body, T, q0 = kpf_body(), camera(), static_pose()
    img = painted_person(body, q0, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)

    def pvel_after_two_steps(**kw):
        cfg = KpfConfig(n_particles=80, iterations=2, partitioned=True, particle_velocity=True,
                        observed_velocity_px=10.0, **kw)
        tr = KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(2))
        tr.start(q0, FrameCues(img, lut), T)
        for _ in range(2):
            res = tr.step(FrameCues(img, lut), T)
        assert np.all(np.isfinite(res.mode)) and np.all(np.isfinite(tr.pvel))
        return tr.pvel, res

    still = np.all(pvel_after_two_steps()[0] == 0.0, axis=1).mean()
    jumped = np.all(pvel_after_two_steps(flip_share=1.0)[0] == 0.0, axis=1).mean()
    assert still < 0.1 and jumped > 0.5, (still, jumped)
    pvel, res = pvel_after_two_steps(lost_cost=1e-3)
    assert res.lost and np.all(pvel == 0.0)


def test_particle_velocities_with_and_without_the_propagation_noise():
    """Built from known parts: ancestors, a velocity per particle used by the motion group
    only, uniform noise and a mean-shift correction. The whole displacement is velocity +
    noise + correction; the innovation form drops the noise (random group: the correction
    alone); ``decay`` scales both; a ``(d,)`` velocity acts as the same row for every
    particle."""
    rng = np.random.default_rng(5)
    n, d = 7, 14
    resampled, v = rng.normal(size=(n, d)), rng.normal(size=(n, d))
    moved = np.arange(n) < 4
    noise, shift = rng.uniform(-1, 1, (n, d)), 0.1 * rng.normal(size=(n, d))
    walked = resampled + v * moved[:, None] + noise
    parts = walked + shift
    whole = particle_velocities(parts, resampled, walked, v, moved, innovation=False)
    assert np.allclose(whole[:4], v[:4] + noise[:4] + shift[:4])
    assert np.allclose(whole[4:], noise[4:] + shift[4:])
    innov = particle_velocities(parts, resampled, walked, v, moved, innovation=True, decay=0.5)
    assert np.allclose(innov[:4], 0.5 * (v[:4] + shift[:4]))
    assert np.allclose(innov[4:], 0.5 * shift[4:])
    one = rng.normal(size=d)
    walked1 = resampled + one * moved[:, None] + noise
    got = particle_velocities(walked1 + shift, resampled, walked1, one, moved, innovation=True)
    assert np.allclose(got, one * moved[:, None] + shift)


def test_tracker_passes_the_restricted_velocity_and_the_clamped_walk(monkeypatch):
    """The innovation velocity's wiring in the tracker: ``particle_velocities`` gets the very
    velocity ``observable_arm_velocity`` returned this frame and the walked particles inside
    the joint limits, and the tracker keeps what it returns."""
    from _kpf_synth import painted_person

    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model
    from humimic.perception.trackers.kpf import tracker as tracker_mod
    from humimic.perception.trackers.kpf.config import KpfConfig
    from humimic.perception.trackers.kpf.frame_cues import FrameCues

    seen: dict = {}

    def spy(name, fn):
        def wrapped(*a, **k):
            seen[name] = (a, fn(*a, **k))
            return seen[name][1]
        monkeypatch.setattr(tracker_mod, name, wrapped)

    spy("observable_arm_velocity", tracker_mod.observable_arm_velocity)
    spy("particle_velocities", tracker_mod.particle_velocities)
    body, T, q0 = kpf_body(), camera(), static_pose()
    img = painted_person(body, q0, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    cfg = KpfConfig(n_particles=80, iterations=2, particle_velocity=True,
                    observed_velocity_px=10.0, particle_velocity_innovation=True)
    tr = tracker_mod.KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(4))
    tr.start(q0, FrameCues(img, lut), T)
    for _ in range(2):
        tr.step(FrameCues(img, lut), T)
        args, out = seen["particle_velocities"]
        parts, resampled, walked, velocity, moved, innovation, decay = args
        assert velocity is seen["observable_arm_velocity"][1]
        assert innovation is True and decay == 1.0
        assert np.all(tr.limits.inside(walked))
        np.testing.assert_array_equal(tr.pvel, out)   # no jumps: every row kept
