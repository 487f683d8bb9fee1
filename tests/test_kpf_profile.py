"""The wrist-depth likelihood profile (``kpf/profile.py``) against closed forms: with a synthetic
log-likelihood ``-|wrist - W*|^2 / (2 s^2)`` whose target ``W*`` lies ``d0`` behind the true
wrist on its camera ray, the profile is the parabola ``-(delta - d0)^2 / (2 s^2)`` at the
offsets the arm can reach (those within its length of the shoulder, by the ray geometry), the
0.5- and 2-nat intervals are ``d0 +- sqrt(d0^2 + 2 n s^2)``, the maximum-likelihood offset is
``d0``, and the wrist mirror's log-likelihood is the parabola's at the other intersection of
the wrist's ray with the forearm's sphere about the elbow (``numpy.roots``). The tracker's own
likelihood on a perfect synthetic image hardly changes along the ray or at the mirror."""

from __future__ import annotations

import numpy as np
import pytest
from _kpf_synth import INTRINSICS, camera, painted_person, static_pose

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.profile import (
    depth_profile,
    ml_choice,
    ml_wrist,
    within,
)
from humimic.perception.trackers.kpf.tracker import kpf_body

S, D0 = 0.05, -0.03


def _setup():
    body, T, q = kpf_body(), camera(), static_pose()
    pose = body.forward(q[None])
    W, E, Sh = (pose.joint(f"r_{j}")[0] for j in ("wrist", "elbow", "shoulder"))
    c = np.linalg.inv(T)[:3, 3]
    u = (W - c) / np.linalg.norm(W - c)
    target = W + D0 * u

    def log_lik(qs):
        w = body.forward(qs).joint("r_wrist")
        return -np.sum((w - target) ** 2, axis=1) / (2 * S * S)
    return body, T, q, W, E, Sh, c, u, log_lik


def test_profile_is_the_closed_form_parabola_where_the_arm_reaches():
    body, T, q, W, E, Sh, c, u, log_lik = _setup()
    delta = np.round(np.arange(-0.3, 0.3001, 0.001), 6)
    p = depth_profile(body, log_lik, q, T, delta)
    assert p.truth == pytest.approx(-D0 ** 2 / (2 * S * S), rel=1e-9)
    sk = body.skeleton
    reach = np.linalg.norm(W + delta[:, None] * u - Sh, axis=1) < sk.upper_arm + sk.forearm
    ok = np.isfinite(p.log_lik)
    assert ok.sum() > 100 and not np.any(ok & ~reach)     # never beyond the arm's length
    np.testing.assert_allclose(p.log_lik[ok], -(delta[ok] - D0) ** 2 / (2 * S * S),
                               atol=1e-11)                # measured 2.3e-14 (was 1e-6)
    lo, hi, censored = within(delta, p.log_lik, p.truth, 0.5)
    half = np.sqrt(D0 ** 2 + 2 * 0.5 * S * S)
    assert not censored
    # linear interpolation on the 1 mm grid: measured 1.8e-6 m off (2026-11-29; the bound was 2e-4)
    assert lo == pytest.approx(D0 - half, abs=5e-6) and hi == pytest.approx(D0 + half, abs=5e-6)
    # 2 nats: the near end from the parabola, the far end where the arm is straight
    lo, hi, censored = within(delta, p.log_lik, p.truth, 2.0)
    assert lo == pytest.approx(D0 - np.sqrt(D0 ** 2 + 2 * 2.0 * S * S), abs=3e-6)  # 1.2e-6
    d = W - Sh          # |d + t u| = upper_arm + forearm, the far root
    L = sk.upper_arm + sk.forearm
    t_max = -u @ d + np.sqrt((u @ d) ** 2 - (d @ d - L * L))
    assert not censored and t_max - 0.0011 <= hi <= t_max
    kind, off = ml_choice(p)
    assert kind == "ray" and off == pytest.approx(D0, abs=1e-12)        # measured 0
    np.testing.assert_allclose(ml_wrist(p), W + D0 * u, atol=1e-12)     # measured 2e-16
    np.testing.assert_allclose(p.wrist[ok], W + delta[ok, None] * u, atol=1e-9)


def _roots(c, u, centre, r):
    """Ranges t of the points c + t u at distance r from centre (numpy.roots)."""
    d = c - centre
    return np.roots([1.0, 2 * u @ d, d @ d - r * r]).real


def test_mirror_wrist_from_the_ray_sphere_intersections():
    body, T, q, W, E, Sh, c, u, log_lik = _setup()
    p = depth_profile(body, log_lik, q, T, np.linspace(-0.1, 0.1, 21))
    assert np.isfinite(p.flip_log_lik["elbow"])
    # the elbow flip: the elbow at its ray's other intersection with the upper arm's sphere
    # about the shoulder, the wrist on its ray at the forearm's sphere's intersection nearer
    # the true wrist
    ue = (E - c) / np.linalg.norm(E - c)
    te = _roots(c, ue, Sh, body.skeleton.upper_arm)
    E_flip = c + te[np.argmax(np.abs(te - np.linalg.norm(E - c)))] * ue
    tw = _roots(c, u, E_flip, body.skeleton.forearm)
    W_flip = c + tw[np.argmin(np.abs(tw - np.linalg.norm(W - c)))] * u
    assert p.flip_wrist_m["elbow"] == pytest.approx(np.linalg.norm(W_flip - W), abs=1e-9)
    np.testing.assert_allclose(p.flip_wrist["elbow"], W_flip, atol=1e-9)
    target = W + D0 * u
    assert p.flip_log_lik["elbow"] == pytest.approx(
        -np.sum((W_flip - target) ** 2) / (2 * S * S), rel=1e-9)
    finite = [v for v in p.flip_log_lik.values() if np.isfinite(v)]
    assert p.flip_margin == pytest.approx(p.truth - max(finite))


def test_within_on_a_hand_made_profile():
    delta = np.array([-0.2, -0.1, 0.0, 0.1, 0.2])
    ll = np.array([np.nan, -1.0, 0.0, -0.5, -3.0])
    lo, hi, censored = within(delta, ll, 0.0, 2.0)
    # the NaN (unreachable) ends it on the left; the crossing on the right interpolated
    assert (lo, hi, censored) == (pytest.approx(-0.1), pytest.approx(0.1 + 0.1 * 1.5 / 2.5),
                                  False)
    assert within(delta, ll, 0.0, 5.0)[1:] == (0.2, True)     # the grid's end: censored
    lo, hi, censored = within(delta, ll, 0.0, 0.5)
    assert lo == pytest.approx(-0.05) and hi == pytest.approx(0.1) and not censored


def test_tracker_likelihood_is_nearly_flat_along_the_ray_and_at_the_mirror():
    """The tracker's own likelihood (eqs. 9-10, fixed sigmas) on the body model painted in flat
    colours at the true pose (no noise, f = 260 px at 2 m, twice the wide eye's f): along the
    wrist's ray it stays within a few nats of the truth's value over +-100 mm (measured: 1.3
    nats above at -100 mm, 0.7 below at +30 mm, the arm straight beyond +40 mm), and the elbow
    mirror, its wrist 212 mm away, scores only 0.6 nats below the truth."""
    body, T, q = kpf_body(), camera(), static_pose()
    img = painted_person(body, q, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    lik = Likelihood(body, INTRINSICS, KpfConfig(sigma_from_spread=False))
    maps = FrameCues(img, lut)
    lik.adapt({k: v[0] for k, v in lik.evaluate(q[None], maps, T).colours.items()})
    delta = np.linspace(-0.1, 0.1, 21)
    p = depth_profile(body, lambda qs: lik.evaluate(qs, maps, T).log_lik, q, T, delta)
    ok = np.isfinite(p.log_lik)
    assert ok.sum() >= 13                                 # -100..+20 mm reachable at least
    assert np.all(np.abs(p.log_lik[ok] - p.truth) < 2.0)
    assert 0.3 < p.flip_margin < 1.0 and p.flip_wrist_m["elbow"] > 0.15


def test_phases_of_the_pointing_cycle():
    from humimic.motion.config import PointMotion
    from humimic.perception.trackers.kpf.profile_run import PHASES, phase

    c = PointMotion(rest=1.0, move=1.5, hold=2.0)
    t = np.array([0.0, 0.99, 1.01, 2.49, 2.51, 4.49, 4.51, 5.99, 6.01, 7.01])
    assert [PHASES[k] for k in phase(t, c)] == ["rest", "rest", "rise", "rise", "hold", "hold",
                                                "lower", "lower", "rest", "rise"]


def test_disparity_change_is_the_difference_of_f_b_over_z():
    from humimic.perception.trackers.kpf.profile_run import disparity_change

    f, b = 134.3, 0.07          # the wide eye at 320 px (100 deg), the DB eyes' baseline
    assert disparity_change(f, b, 2.0, 0.02) == pytest.approx(f * b / 2.0 - f * b / 2.02)
    # small changes: f b dz / z^2
    assert disparity_change(f, b, 2.0, 1e-4) == pytest.approx(f * b * 1e-4 / 4.0, rel=1e-4)


def test_command_writes_the_profile_and_plot(tmp_path, capsys):
    """Two frames of side pointing: every frame profiled, JSON and PNG written, the summary
    printed with the eyes' baseline read from the robot model (70 mm), and the same summary
    from the JSON (``--from``)."""
    import json

    from humimic.perception.reproduce import main

    assert main(["schmidt-depth-profile", "--gesture", "side", "--seeds", "1", "--duration",
                 "0.2", "--range", "50", "--torso-offset", "0", "0", "0",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "baseline 70.0 mm" in out and "side   rest    2" in out
    d = json.loads((tmp_path / "profile.json").read_text())
    assert len(d["delta_m"]) == 11 and len(d["frames"]["side"]) == 2
    for r in d["frames"]["side"]:   # around the truth: the ray's wrists |delta| from it
        ok = np.isfinite(r["log_lik"])
        np.testing.assert_allclose(np.array(r["ray_error_m"])[ok],
                                   np.abs(d["delta_m"])[ok], atol=1e-9)
    assert (tmp_path / "depth_profile.png").stat().st_size > 1000
    assert main(["schmidt-depth-profile", "--from", str(tmp_path)]) == 0   # re-summarised
    again = capsys.readouterr().out
    assert again.strip() == out[out.index("wide eye"):out.index("plot:")].strip()


def test_rescaled_profile_narrows_as_the_square_root():
    """Scaling a parabola -x^2 / (2 s^2) by k narrows its n-nat interval by sqrt(k): at k = 4
    the 2-nat interval is the unscaled 0.5-nat one (+-s); the mirror's margin scales by k."""
    from humimic.perception.trackers.kpf.profile_report import rescaled

    delta = np.linspace(-0.2, 0.2, 401)
    row = {"log_lik": (-delta ** 2 / (2 * S * S)).tolist(), "flip_rel": {"wrist": -0.3},
           "within_0.5": None, "within_2": None}
    (r,) = rescaled([row], delta, 4.0)
    lo, hi, censored = r["within_2"]
    assert lo == pytest.approx(-S, abs=1e-4) and hi == pytest.approx(S, abs=1e-4)
    assert not censored and r["flip_rel"]["wrist"] == pytest.approx(-1.2)


@pytest.mark.parametrize("args", [["--seeds", "0"], ["--step", "0"], ["--range", "-5"],
                                  ["--scale", "0"]])
def test_profile_arguments_that_cannot_run_exit_2(capsys, args):
    """A count of no seeds, a zero step (a division), a negative range (an empty grid) or a
    scale <= 0 (flipped intervals): one line naming the argument, exit 2, nothing rendered."""
    from humimic.perception.reproduce import main

    assert main(["schmidt-depth-profile", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and args[0] in err, err


def test_schmidt_command_not_first_exits_2_in_one_line(capsys):
    """``reproduce --seed 1 schmidt-table1``: the usage lists the Schmidt commands, which take
    their own arguments; given after an option they exit 2 with a usage error (was a KeyError
    traceback)."""
    from humimic.perception.reproduce import main

    with pytest.raises(SystemExit) as exc:
        main(["--seed", "1", "schmidt-table1"])
    assert exc.value.code == 2
    assert "schmidt-table1 must come first" in capsys.readouterr().err
