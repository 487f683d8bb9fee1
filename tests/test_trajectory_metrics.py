"""ATE/RPE computed in the project agree with evo on real data (TUM RGB-D fr1_xyz: RGB-D SLAM
and monocular ORB-SLAM against motion-capture ground truth, shipped in data/trajectories), and
the Umeyama alignment recovers a known similarity."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.evaluate import main
from humimic.maths.align import apply_alignment, umeyama
from humimic.maths.trajectory import (
    ape,
    associate,
    poses_from,
    read_tum,
    relative_poses,
    rpe,
    write_tum,
)

evo_metrics = pytest.importorskip("evo.core.metrics")
from evo.core import sync  # noqa: E402
from evo.tools import file_interface  # noqa: E402

GT = "freiburg1_xyz-groundtruth.txt"
ESTIMATES = ["freiburg1_xyz-rgbdslam.txt", "freiburg1_xyz-ORB_kf_mono.txt"]


def _evo(data_dir, est, kind, align, delta=1):
    ref = file_interface.read_tum_trajectory_file(data_dir / "trajectories" / GT)
    traj = file_interface.read_tum_trajectory_file(data_dir / "trajectories" / est)
    ref, traj = sync.associate_trajectories(ref, traj, max_diff=0.01)
    if align != "none":
        traj.align(ref, correct_scale=align == "sim3")
    if kind == "ape":
        m = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    else:
        m = evo_metrics.RPE(evo_metrics.PoseRelation.translation_part, delta=delta,
                            delta_unit=evo_metrics.Unit.frames, all_pairs=False)
    m.process_data((ref, traj))
    return m.get_statistic(evo_metrics.StatisticsType.rmse), len(m.error)


@pytest.mark.parametrize("est", ESTIMATES)
@pytest.mark.parametrize("align", ["none", "se3", "sim3"])
def test_ape_matches_evo(data_dir, est, align):
    t_ref, T_ref = read_tum(data_dir / "trajectories" / GT)
    t_est, T_est = read_tum(data_dir / "trajectories" / est)
    ours = ape(t_ref, T_ref, t_est, T_est, align)
    theirs, n = _evo(data_dir, est, "ape", align)
    assert ours.pairs == n
    assert ours.rmse_m == pytest.approx(theirs, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("est", ESTIMATES)
@pytest.mark.parametrize("delta", [1, 10])
@pytest.mark.parametrize("align", ["none", "sim3"])
def test_rpe_matches_evo(data_dir, est, delta, align):
    t_ref, T_ref = read_tum(data_dir / "trajectories" / GT)
    t_est, T_est = read_tum(data_dir / "trajectories" / est)
    ours = rpe(t_ref, T_ref, t_est, T_est, delta, align)
    theirs, n = _evo(data_dir, est, "rpe", align, delta)
    assert ours.pairs == n
    assert ours.rmse_m == pytest.approx(theirs, rel=1e-9, abs=1e-12)


def test_association_matches_evo(data_dir):
    t_ref, _ = read_tum(data_dir / "trajectories" / GT)
    t_est, _ = read_tum(data_dir / "trajectories" / ESTIMATES[0])
    i, j = associate(t_ref, t_est)
    i_evo, j_evo = sync.matching_time_indices(t_est, t_ref, 0.01)  # evo: shorter first
    np.testing.assert_array_equal(j, i_evo)
    np.testing.assert_array_equal(i, j_evo)
    assert np.all(np.abs(t_ref[i] - t_est[j]) <= 0.01)


def test_umeyama_recovers_a_similarity():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(50, 3))
    R = Rotation.from_rotvec([0.3, -1.2, 0.7]).as_matrix()
    t, s = np.array([1.0, -2.0, 0.5]), 0.37
    dst = s * src @ R.T + t
    R_hat, t_hat, s_hat = umeyama(src, dst, with_scale=True)
    np.testing.assert_allclose(R_hat, R, atol=1e-12)
    np.testing.assert_allclose(t_hat, t, atol=1e-12)
    assert s_hat == pytest.approx(s, rel=1e-12)
    # without scale: still a proper rotation (no reflection) even for mirrored data
    R2, _, s2 = umeyama(src, src * [1, 1, -1])
    assert np.linalg.det(R2) == pytest.approx(1.0) and s2 == 1.0


def test_aligned_copy_has_zero_ape_and_rpe_is_frame_invariant():
    rng = np.random.default_rng(1)
    t = np.arange(100) * 0.1
    T = poses_from(np.cumsum(rng.normal(0, 0.05, (100, 3)), axis=0),
                   Rotation.from_rotvec(rng.normal(0, 0.3, (100, 3))).as_quat())
    R = Rotation.from_rotvec([0.2, 0.1, -0.4]).as_matrix()
    moved = apply_alignment(T, R, np.array([3.0, 1.0, 0.0]), 1.0)
    assert ape(t, T, t, moved, "none").rmse_m > 1.0
    assert ape(t, T, t, moved, "se3").rmse_m < 1e-9
    assert rpe(t, T, t, moved, 5).rmse_m < 1e-9  # relative motion does not see the frame
    rel = relative_poses(T, 1)
    np.testing.assert_allclose(T[0] @ rel[0], T[1], atol=1e-12)


def test_cli_prints_the_rmse_and_rejects_bad_input(data_dir, tmp_path, capsys):
    gt = str(data_dir / "trajectories" / GT)
    est = str(data_dir / "trajectories" / ESTIMATES[0])
    assert main(["ape", gt, est, "--align", "se3"]) == 0
    out = capsys.readouterr().out
    assert float(out.split()[2]) == pytest.approx(0.013470, abs=1e-6)  # evo_ape -a: 0.013470
    assert main(["rpe", gt, est, "--delta", "10"]) == 0
    assert float(capsys.readouterr().out.split()[2]) == pytest.approx(0.014610, abs=1e-6)
    bad = tmp_path / "bad.txt"
    bad.write_text("0 1 2 3\n")
    assert main(["ape", gt, str(bad)]) == 2
    assert "8 columns" in capsys.readouterr().err
    # a round trip through write_tum
    t, T = read_tum(est)
    write_tum(tmp_path / "copy.txt", t, T)
    assert main(["ape", est, str(tmp_path / "copy.txt")]) == 0
    assert float(capsys.readouterr().out.split()[2]) < 1e-8
