"""The kpf's delayed flip-branch decision (``kpf/branches.py``) against independent
computations: the CUSUM with forgetting against its closed form (the largest discounted sum of
the latest ratios, Page's max form), a switch of a static arm on the frame that closed form
predicts, the switched arm keeping its elbow and wrist pixels (the camera model's projection)
for the estimate and every particle."""

from __future__ import annotations

import numpy as np

from humimic.perception.trackers.kpf.branches import (
    FlipBranches,
    branch_switches,
    cusum_update,
    flip_arm,
    gate_near_flips,
    wrist_separation,
)
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.flips import FLIPS, arm_flips
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.sensors.camera_model import Intrinsics


def _camera(x: float = 2.0, y: float = 0.1) -> np.ndarray:
    """T_cam_base of a camera at (x, y, 1.3) looking back along -x (OpenCV axes)."""
    R_base_cam = np.column_stack([[0, 1, 0], [0, 0, -1], [-1, 0, 0]]).astype(float)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_base_cam.T, -R_base_cam.T @ np.array([x, y, 1.3])
    return T


def _closed_form(r: np.ndarray, lam: float) -> float:
    """max(0, max_k sum_{t >= k} lam^(T - t) r_t): the CUSUM recursion's value after r."""
    T = len(r)
    best = 0.0
    for k in range(T):
        best = max(best, sum(lam ** (T - 1 - t) * r[t] for t in range(k, T)))
    return best


def test_cusum_with_forgetting_is_the_largest_discounted_recent_sum():
    rng = np.random.default_rng(0)
    for lam in (1.0, 0.9, 0.5):
        r = rng.normal(0.05, 0.4, (40, 6))
        S = np.zeros(6)
        for t in range(40):
            S = cusum_update(S, r[t], lam)
            want = [_closed_form(r[:t + 1, i], lam) for i in range(6)]
            np.testing.assert_allclose(S, want, rtol=1e-12, atol=1e-12)
    S = cusum_update(np.array([2.0, 2.0]), np.array([np.nan, 0.1]), 0.9)
    np.testing.assert_allclose(S, [0.0, 1.9])          # a missing flip restarts its sum


def test_branch_switches_pick_the_largest_sum_over_the_threshold():
    S = np.array([[0.2, 1.4, 0.9], [0.5, 0.4, 0.3], [2.0, 3.0, 1.0]])
    np.testing.assert_array_equal(branch_switches(S, 1.0), [1, -1, 1])


def _arm_poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = np.zeros((n, 14))
    q[:, 2], q[:, 3] = 1.1, np.pi                      # standing, facing the camera
    q[:, 6:10] = rng.uniform([-0.3, 0.1, -0.8, 0.3], [1.4, 1.4, 0.8, 1.5], (n, 4))
    q[:, 10:14] = rng.uniform([-0.3, 0.1, -0.8, 0.3], [1.4, 1.4, 0.8, 1.5], (n, 4))
    return kpf_body().free_limits.clamp(q)


def test_flip_arm_keeps_the_joint_pixels_or_takes_the_fallback():
    body = kpf_body()
    intr = Intrinsics(320, 240, 260.0, 260.0, 159.5, 119.5)
    T = _camera()
    c = np.linalg.inv(T)[:3, 3]
    q = _arm_poses(300, 4)
    fallback = q[0].copy()
    fallback[6:10] = [0.1, 0.2, 0.3, 0.4]
    for kind in FLIPS:
        out = flip_arm(body, q, "R", kind, c, body.free_limits, fallback)
        np.testing.assert_array_equal(out[:, 10:], q[:, 10:])
        np.testing.assert_array_equal(out[:, :6], q[:, :6])
        raw = arm_flips(body, q, "R", c)[kind]
        ok = np.all(np.isfinite(raw), axis=1)
        ok[ok] = body.free_limits.inside(raw[ok])
        assert 0.1 < ok.mean() < 1.0   # measured 0.32 / 0.84 / 0.97: the fallback is taken
        np.testing.assert_array_equal(out[~ok, 6:10], np.broadcast_to(fallback[6:10],
                                                                      (np.sum(~ok), 4)))
        a, b = body.forward(q[ok]), body.forward(out[ok])
        for j in ("r_elbow", "r_wrist"):
            np.testing.assert_allclose(intr.project(b.to(T).joint(j)),
                                       intr.project(a.to(T).joint(j)), atol=1e-6)


class _Tracker:
    """The parts of a KpfTracker the branch decision touches; the log-posterior rewards a
    right wrist near the camera by ``k`` nats per metre."""

    def __init__(self, body, q, particles, c, k):
        self.body, self.limits, self.c, self.k = body, body.free_limits, c, k
        self.mode, self.particles = q.copy(), particles.copy()
        self.pvel = np.ones_like(particles)

    def _log_post(self, q, maps, T, floors=False):
        return -self.k * np.linalg.norm(self.body.forward(q).joint("r_wrist") - self.c, axis=1)


def test_a_static_arm_switches_on_the_frame_the_cusum_predicts():
    body = kpf_body()
    T = _camera()
    c = np.linalg.inv(T)[:3, 3]
    qs = _arm_poses(200, 9)
    flips = arm_flips(body, qs, "R", c)
    rng_w = {k: np.linalg.norm(body.forward(f).joint("r_wrist") - c, axis=1)
             for k, f in flips.items()}
    here = np.linalg.norm(body.forward(qs).joint("r_wrist") - c, axis=1)
    gain = {k: here - rng_w[k] for k in FLIPS}          # metres nearer the camera
    # a pose whose best flip is clearly nearer and within the limits
    best = np.nanmax(np.column_stack([gain[k] for k in FLIPS]), axis=1)
    valid = np.all([body.free_limits.inside(np.nan_to_num(flips[k])) for k in FLIPS], axis=0)
    i = int(np.argmax(np.where(valid, best, -np.inf)))
    assert best[i] > 0.5                                # measured 1.02 m (was 0.1)
    q = qs[i]
    k_nats, lam, h = 0.5, 0.9, 1.0
    cfg = KpfConfig(branch_threshold=h, branch_forget=lam)
    particles = q + np.random.default_rng(1).normal(0, 0.02, (50, 14)) * (np.arange(14) >= 6)
    tr = _Tracker(body, q, particles, c, k_nats)
    br = FlipBranches(body, None, cfg)
    kinds = np.array([k_nats * gain[k][i] for k in FLIPS])
    top = int(np.argmax(kinds))
    # the closed form: S_t = r (1 - lam^t) / (1 - lam) passes h on frame t*
    t_star = next(t for t in range(1, 100) if kinds[top] * (1 - lam ** t) / (1 - lam) > h)
    mode = q.copy()
    for t in range(1, t_star + 1):
        before = mode.copy()
        mode = br.step(tr, mode, None, T)
        switched = not np.array_equal(mode, before)
        assert switched == (t == t_star), t
    want = flips[FLIPS[top]][i]
    np.testing.assert_allclose(mode, want, atol=1e-12)
    np.testing.assert_allclose(tr.mode, want, atol=1e-12)      # the last estimate too
    np.testing.assert_array_equal(br.S[0], 0.0)
    assert np.all(tr.pvel[:, 6:10] == 0.0) and np.all(tr.pvel[:, 10:] == 1.0)
    moved = np.linalg.norm(body.forward(tr.particles).joint("r_wrist")
                           - body.forward(particles).joint("r_wrist"), axis=1)
    assert np.median(moved) > 0.5                # the particles went with it (measured 1.02 m)


def test_refined_ratios_compare_each_branchs_local_peak():
    """With ``branch_refine_polls`` the estimate's arm and each flip are moved uphill first.
    Without, a ratio is the flip's log-posterior minus the estimate's (computed here); with,
    it differs, and lies within what refinement can reach: the log-posterior here (minus
    ``k`` times the wrist's distance to the camera) is at most 0 and refinement never scores
    lower, so ``lp(flip) <= r <= -lp(estimate)``."""
    body = kpf_body()
    T = _camera()
    c = np.linalg.inv(T)[:3, 3]
    q = _arm_poses(40, 9)[3]
    tr = _Tracker(body, q, q[None].repeat(5, 0), c, 0.5)
    tr.D = np.full(14, 0.05)

    def lp(x):
        return float(tr._log_post(np.atleast_2d(x), None, T)[0])

    flat = FlipBranches(body, None, KpfConfig(branch_threshold=50.0))
    flat.step(tr, q.copy(), None, T)
    refined = FlipBranches(body, None, KpfConfig(branch_threshold=50.0, branch_refine_polls=3))
    refined.step(tr, q.copy(), None, T)
    r0, r1 = flat.history[-1][0][0], refined.history[-1][0][0]       # the right arm's row
    np.testing.assert_array_equal(np.isnan(r1), np.isnan(r0))
    flips = arm_flips(body, q[None], "R", c)
    assert np.isfinite(r0).sum() >= 2
    for k, kind in enumerate(FLIPS):
        if np.isnan(r0[k]):
            continue
        np.testing.assert_allclose(r0[k], lp(flips[kind][0]) - lp(q), atol=1e-12)
        assert lp(flips[kind][0]) <= r1[k] <= -lp(q) and abs(r1[k] - r0[k]) > 1e-6


def test_wrist_separation_of_the_wrist_flip_is_the_chord_of_its_ray():
    """The wrist flip moves the wrist to the other point where its camera ray meets the
    forearm's sphere about the elbow: the two are a chord apart, ``2 sqrt(l^2 - d^2)`` with
    ``d`` the elbow's distance to the ray (computed here from the joints)."""
    body = kpf_body()
    c = np.linalg.inv(_camera())[:3, 3]
    qs = _arm_poses(30, 5)
    pose = body.forward(qs)
    E, W = pose.joint("r_elbow"), pose.joint("r_wrist")
    u = (W - c) / np.linalg.norm(W - c, axis=1, keepdims=True)
    v = E - c
    d2 = np.sum(v * v, axis=1) - np.sum(v * u, axis=1) ** 2
    chord = 2.0 * np.sqrt(body.skeleton.forearm ** 2 - d2)
    flips = arm_flips(body, qs, "R", c)
    for i in range(len(qs)):
        got = wrist_separation(body, qs[i], flips["wrist"][i:i + 1], "R")
        np.testing.assert_allclose(got, [chord[i]], atol=1e-9)
    both = np.vstack([flips["wrist"][0], np.full(14, np.nan)])
    sep = wrist_separation(body, qs[0], both, "R")
    assert np.isfinite(sep[0]) and np.isnan(sep[1])      # a missing flip has no separation


def test_near_flips_leave_the_cusum():
    r = np.array([[0.3, -0.2, np.nan], [0.1, 0.4, 0.2]])
    sep = np.array([[0.10, 0.30, np.nan], [0.25, 0.15, 0.20]])
    np.testing.assert_array_equal(gate_near_flips(r, sep, None), r)
    np.testing.assert_array_equal(gate_near_flips(r, sep, 0.2),
                                  [[np.nan, -0.2, np.nan], [0.1, np.nan, 0.2]])


def test_a_static_arm_never_switches_to_a_flip_nearer_than_the_separation():
    """The static arm of the CUSUM test above (the flips nearer the camera win every frame):
    with ``branch_min_separation_mm`` between the flips' wrist separations only the far ones
    keep a ratio and may be switched to; above them all, no sum grows and nothing switches."""
    body = kpf_body()
    T = _camera()
    c = np.linalg.inv(T)[:3, 3]
    qs = _arm_poses(200, 9)
    fl = arm_flips(body, qs, "R", c)
    ok = np.column_stack([body.free_limits.inside(np.nan_to_num(fl[k])) & np.all(np.isfinite(
        fl[k]), axis=1) for k in FLIPS])
    i = int(np.argmax(ok.sum(1)))
    q, flips = qs[i], {k: fl[k][i:i + 1] for k in FLIPS}
    sep = np.array([np.linalg.norm(body.forward(flips[k]).joint("r_wrist")[0]
                                   - body.forward(q[None]).joint("r_wrist")[0])
                    if ok[i, j] else np.nan for j, k in enumerate(FLIPS)])
    assert np.sum(np.isfinite(sep)) == 3
    cut = float(np.nanmean(sep))
    for mm, far in ((1000 * cut, sep >= cut), (1000 * (np.nanmax(sep) + 0.01), sep < 0)):
        tr = _Tracker(body, q, q[None].repeat(5, 0), c, 0.5)
        br = FlipBranches(body, None, KpfConfig(branch_threshold=50.0,
                                                branch_min_separation_mm=mm))
        br.step(tr, q.copy(), None, T)
        r = br.history[-1][0][0]
        np.testing.assert_array_equal(np.isfinite(r), far & np.isfinite(sep))
        np.testing.assert_allclose(br.separations[-1][0], sep, atol=1e-9)
    assert np.all(br.S == 0.0) and np.array_equal(tr.mode, q)


def test_a_moving_arm_is_not_scored():
    """``branch_max_step_mm``: an arm whose estimated wrist moved farther than it since the
    last estimate gets no ratios (its sums restart); a still arm is scored as without it."""
    body = kpf_body()
    T = _camera()
    c = np.linalg.inv(T)[:3, 3]
    q = _arm_poses(40, 9)[3]
    last = q.copy()
    last[9] += 0.3                                   # the right elbow bent 0.3 rad less
    moved = np.linalg.norm(body.forward(last[None]).joint("r_wrist")
                           - body.forward(q[None]).joint("r_wrist"))
    assert moved > 0.05
    rows = []
    for mm in (None, 1000 * moved - 1.0, 1000 * moved + 1.0):
        cfg = KpfConfig(branch_threshold=50.0) if mm is None else \
            KpfConfig(branch_threshold=50.0, branch_max_step_mm=mm)
        tr = _Tracker(body, last, q[None].repeat(5, 0), c, 0.5)
        br = FlipBranches(body, None, cfg)
        br.step(tr, q.copy(), None, T)
        np.testing.assert_allclose(br.steps[-1], [moved, 0.0], atol=1e-9)
        rows.append(br.history[-1][0])
    free, moving, still = rows
    assert np.isfinite(free[0]).sum() >= 1
    assert np.all(np.isnan(moving[0])) and np.array_equal(moving[1], free[1], equal_nan=True)
    np.testing.assert_array_equal(still, free)


def test_clipped_ratios_delay_the_switch_to_the_frame_the_capped_sum_predicts():
    """``branch_max_ratio``: the static arm of the CUSUM test, its best flip's ratio clipped to
    ``cap`` (between it and the runner-up): it switches on the frame at which
    ``cap (1 - lam^t) / (1 - lam)`` passes the threshold, later than unclipped."""
    body = kpf_body()
    T = _camera()
    c = np.linalg.inv(T)[:3, 3]
    qs = _arm_poses(200, 9)
    flips = arm_flips(body, qs, "R", c)
    here = np.linalg.norm(body.forward(qs).joint("r_wrist") - c, axis=1)
    gain = {k: here - np.linalg.norm(body.forward(f).joint("r_wrist") - c, axis=1)
            for k, f in flips.items()}
    best = np.nanmax(np.column_stack([gain[k] for k in FLIPS]), axis=1)
    valid = np.all([body.free_limits.inside(np.nan_to_num(flips[k])) for k in FLIPS], axis=0)
    i = int(np.argmax(np.where(valid, best, -np.inf)))
    k_nats, lam = 0.5, 0.9
    kinds = np.array([k_nats * gain[k][i] for k in FLIPS])
    top = int(np.argmax(kinds))
    cap = 0.5 * (kinds[top] + max(np.sort(kinds)[-2], 0.0))
    h = 3.0 * cap
    t_cap = next(t for t in range(1, 100) if cap * (1 - lam ** t) / (1 - lam) > h)
    t_free = next(t for t in range(1, 100) if kinds[top] * (1 - lam ** t) / (1 - lam) > h)
    assert t_cap > t_free
    tr = _Tracker(body, qs[i], qs[i][None].repeat(5, 0), c, k_nats)
    br = FlipBranches(body, None, KpfConfig(branch_threshold=h, branch_forget=lam,
                                            branch_max_ratio=cap))
    mode = qs[i].copy()
    for t in range(1, t_cap + 1):
        before = mode.copy()
        mode = br.step(tr, mode, None, T)
        assert (not np.array_equal(mode, before)) == (t == t_cap), t
        assert np.nanmax(np.abs(br.history[-1][0])) <= cap
    np.testing.assert_allclose(mode, flips[FLIPS[top]][i], atol=1e-12)


def test_a_flip_outside_the_limits_is_scored_clamped():
    """``branch_clamp_flips``: a flip that leaves the joint limits gets no ratio without it;
    with it, the ratio of the flip clamped into the limits (without refinement: the
    log-posterior's difference at the clamped pose, computed here), and a switch to it leaves
    the estimate within the limits."""
    body = kpf_body()
    T = _camera()
    c = np.linalg.inv(T)[:3, 3]
    qs = _arm_poses(200, 9)
    fl = arm_flips(body, qs, "R", c)
    out = np.column_stack([np.all(np.isfinite(fl[k]), axis=1)
                           & ~body.free_limits.inside(np.nan_to_num(fl[k])) for k in FLIPS])
    i, k = map(int, np.argwhere(out)[0])
    q = qs[i]
    tr = _Tracker(body, q, q[None].repeat(5, 0), c, 0.5)

    def lp(x):
        return float(tr._log_post(np.atleast_2d(x), None, T)[0])

    off = FlipBranches(body, None, KpfConfig(branch_threshold=50.0))
    off.step(tr, q.copy(), None, T)
    assert np.isnan(off.history[-1][0][0, k])
    on = FlipBranches(body, None, KpfConfig(branch_threshold=50.0, branch_clamp_flips=True))
    on.step(tr, q.copy(), None, T)
    clamped = np.clip(fl[FLIPS[k]][i], body.free_limits.lower, body.free_limits.upper)
    np.testing.assert_allclose(on.history[-1][0][0, k], lp(clamped) - lp(q), atol=1e-12)
    if on.history[-1][0][0, k] > 0:                      # it switches with a low threshold
        low = FlipBranches(body, None, KpfConfig(branch_threshold=1e-6,
                                                 branch_clamp_flips=True))
        low.step(tr, q.copy(), None, T)
        assert body.free_limits.inside(tr.mode[None])[0]
