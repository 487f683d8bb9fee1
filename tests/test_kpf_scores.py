"""``truth_margin_scores`` (the kpf's likelihood at the truth against its estimate) against a
plain-Python count over the finite frames."""

from __future__ import annotations

import math

import numpy as np

from humimic.perception.trackers.kpf.scores import truth_margin_scores


def test_truth_margin_scores_match_a_plain_count():
    rng = np.random.default_rng(0)
    m = rng.normal(0.3, 1.0, 200)
    m[rng.random(200) < 0.1] = np.nan
    got = truth_margin_scores(m)
    finite = [float(x) for x in m if not math.isnan(x)]
    assert math.isclose(got["truth_margin_nats"], sum(finite) / len(finite), rel_tol=1e-12)
    assert got["estimate_above_truth_fraction"] == sum(x < 0 for x in finite) / len(finite)
    assert truth_margin_scores(np.full(3, np.nan)) == {
        "truth_margin_nats": None, "estimate_above_truth_fraction": None}


def test_left_arm_scores_are_the_left_joints_distances(monkeypatch):
    """The left arm's scores (a straight hanging arm the tracker bends shows only there)
    against a plain loop over frames: the estimate's left wrist/elbow from its own forward
    kinematics, the truth's from the true state's."""
    from humimic.perception.trackers.kpf import scores
    from humimic.perception.trackers.kpf.tracker import kpf_body

    body = kpf_body()
    rng = np.random.default_rng(1)
    n = 6
    q_true = np.zeros((n, 14))
    q_true[:, 2] = 1.1
    q_true[:, 6:14] = rng.uniform([-0.3, 0.1, -0.8, 0.3] * 2, [1.4, 1.4, 0.8, 1.5] * 2, (n, 8))
    q_true = body.free_limits.clamp(q_true)
    q_est = body.free_limits.clamp(q_true + rng.normal(0.0, 0.2, q_true.shape))
    pose_t, pose_e = body.forward(q_true), body.forward(q_est)
    j_true = np.stack([pose_t.joint(j) for j in scores.ENDPOINTS], axis=1)
    monkeypatch.setattr(scores, "truth", lambda world, body, t: (q_true, j_true))
    rec = scores.KpfRecord()
    T = np.eye(4)
    T[:3, :3] = np.column_stack([[0, 1, 0], [0, 0, -1], [-1, 0, 0]]).T
    T[:3, 3] = -T[:3, :3] @ np.array([2.0, 0.0, 1.3])
    for k in range(n):
        rec.add(k / 7.5, q_est[k], {j: pose_e.joint(j)[k] for j in scores.ENDPOINTS}, False,
                0.01, 0.01, 2, T)
    m = scores.kpf_metrics(rec, None, body, "L_wide")
    for name, joint in (("left_wrist_error_mm", "l_wrist"), ("left_elbow_error_mm", "l_elbow")):
        d = [math.dist(pose_e.joint(joint)[k], pose_t.joint(joint)[k]) for k in range(n)]
        assert math.isclose(m[name], 1e3 * sum(d) / n, rel_tol=1e-9)
    a = [(q_est[k, i] - q_true[k, i] + math.pi) % (2 * math.pi) - math.pi
         for k in range(n) for i in range(10, 14)]
    assert math.isclose(m["left_arm_rmse_deg"],
                        math.degrees(math.sqrt(sum(x * x for x in a) / len(a))), rel_tol=1e-9)
