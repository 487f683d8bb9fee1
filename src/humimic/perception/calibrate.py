"""Calibrate the measurement noise the filter receives: ``perception.pixel_std`` and
``perception.match_std`` from a scenario's own renders.

``python -m humimic.perception.calibrate SCENARIO.yaml [--seed N] [--duration S] [--set K=V]
[--out DIR]``

Each 3-D measurement's covariance is ``R = pixel_std^2 R_c + match_std^2 R_m``: ``R_c`` the
triangulated covariance of a unit blob-centre error that the right match follows, ``R_m`` that
of a unit match error along the epipolar line (the ``following`` model,
:func:`~humimic.perception.blobs.stereo.following_covariance`). The run's measurement errors
against the ground truth, each target's mean removed (a bias is no noise: the head's stereo
surface sits ~20 mm in front of its centre whatever R says), are fitted by least squares,
``e e^T ~ pixel_std^2 R_c + match_std^2 R_m`` over every frame and target. Printed: the two
values, the YAML lines to put in the scenario, and the fraction of frames whose measurement
NEES (3 dof) lies inside its 95 % chi-square band with the scenario's values and with the
fitted ones, against the truth and with the bias removed.

Why per scenario: in the simulation the blob-centre jitter comes from EM's sampling grid and
the pixel noise, and the match error from the blob's outline and its motion, so they vary with
resolution, blob size and speed (measured on the shipped scenarios: 0.15-0.31 px and
0.014-0.044 px). A 2-D noise of the paper's kind (0.65 px^2) is ~10x larger than ours.
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse
import sys
from pathlib import Path

import numpy as np

from humimic.errors import InputError, report_error
from humimic.maths.stats import fraction_in_band, nees
from humimic.metrics.tracking import FILTER_SETTLE_S
from humimic.perception.blobs.stereo import (
    StereoRig,
    epipolar_direction,
    following_covariance,
    small_blob_scale,
)
from humimic.perception.blobs.triangulation import NOISE_REF_SIGMA_PX


def unit_covariances(pa, i: int, frames: np.ndarray,
                     noise_ref_sigma_px: float | None = NOISE_REF_SIGMA_PX
                     ) -> tuple[np.ndarray, np.ndarray]:
    """``(R_c, R_m)``, each ``(len(frames), 3, 3)`` (m^2 per px^2): target ``i``'s triangulated
    covariance for a unit blob-centre error (followed by the match) and for a unit match error
    along the epipolar line, at its recorded correspondences, each grown as the stage grows it
    for a blob smaller than ``noise_ref_sigma_px`` (``perception.noise_ref_sigma_px``,
    :func:`~humimic.perception.blobs.triangulation.small_blob_scale` of the left blob)."""
    k2 = np.square(small_blob_scale(pa.cov[frames, i, 0], noise_ref_sigma_px))
    Rc, Rm = [], []
    for f in frames.tolist():
        cl, cr = pa.camera(f, 0), pa.camera(f, 1)
        uv_l, uv_r = pa.uv_match[f, i]
        t = epipolar_direction(cl, cr, pa.p_base[f, i])[None]
        rig = StereoRig(cl, cr)
        Rc.append(rig.triangulate(uv_l, uv_r, cov_joint=following_covariance(
            np.eye(2), 0.0, t)[0])[1])
        Rm.append(rig.triangulate(uv_l, uv_r, cov_joint=following_covariance(
            np.zeros((2, 2)), 1.0, t)[0])[1])
    return (k2[:, None, None] * np.array(Rc).reshape(-1, 3, 3),
            k2[:, None, None] * np.array(Rm).reshape(-1, 3, 3))


def fit_pixel_noise(err: np.ndarray, Rc: np.ndarray, Rm: np.ndarray) -> tuple[float, float]:
    """``(pixel_std, match_std)`` (px) minimising ``sum_k ||e_k e_k^T - s_c^2 Rc_k - s_m^2
    Rm_k||_F^2`` (linear least squares in the variances, clipped at 0) for zero-mean errors
    ``err (N, 3)``."""
    E = np.einsum("ni,nj->nij", err, err).reshape(-1)
    A = np.stack([Rc.reshape(-1), Rm.reshape(-1)], axis=1)
    var, *_ = np.linalg.lstsq(A, E, rcond=None)
    return float(np.sqrt(max(var[0], 0.0))), float(np.sqrt(max(var[1], 0.0)))


def calibration_data(pa, truth: dict, skip_s: float = FILTER_SETTLE_S,
                     noise_ref_sigma_px: float | None = NOISE_REF_SIGMA_PX) -> dict:
    """Per published target with measurements: its frames (``skip_s`` after its first
    measurement), errors ``(N, 3)`` against the truth, recorded R and unit covariances."""
    out = {}
    for target, (p, _, _) in truth.items():
        i = pa.index(target)
        ok = pa.ok[:, i]
        if ok.sum() < 10:
            continue
        frames = np.flatnonzero(ok & (pa.t >= pa.t[np.argmax(ok)] + skip_s))
        Rc, Rm = unit_covariances(pa, i, frames, noise_ref_sigma_px)
        k2 = np.square(small_blob_scale(pa.cov[frames, i, 0], noise_ref_sigma_px))
        out[target] = {"err": pa.p_base[frames, i] - p[frames], "R": pa.R_base[frames, i],
                       "Rc": Rc, "Rm": Rm, "Rf": Rm / k2[:, None, None]}
    return out


def in_band(err: np.ndarray, R: np.ndarray) -> tuple[float, float]:
    """Fractions of measurement NEES (3 dof) inside the 95 % band: against the truth, and
    with the mean error (the bias) removed."""
    return (fraction_in_band(nees(err, R), 3),
            fraction_in_band(nees(err - err.mean(axis=0), R), 3))


def calibrate(archive, noise_ref_sigma_px: float | None = NOISE_REF_SIGMA_PX,
              match_floor_px: float | None = None) -> tuple[float, float, dict]:
    """Fit on a run's ``tracking.npz`` (:class:`~humimic.perception.blobs.archive.
    TrackingArchive`): ``(pixel_std, match_std, per-target NEES fractions before/after)``; the
    noises hold for blobs ``noise_ref_sigma_px`` wide (the scenario's). The fit sees the errors
    with each target's mean removed, so a ``perception.match_floor_px`` (the outline's
    rounding, constant while a target is still) is not fitted; the 'after' fractions add it
    as the stage does (:func:`~humimic.perception.blobs.triangulation.match_noise_px`)."""
    data = calibration_data(archive.perception, archive.truth,
                            noise_ref_sigma_px=noise_ref_sigma_px)
    if not data:
        raise InputError("no target was measured in at least 10 frames: nothing to calibrate")
    e = np.concatenate([d["err"] - d["err"].mean(axis=0) for d in data.values()])
    s_c, s_m = fit_pixel_noise(e, np.concatenate([d["Rc"] for d in data.values()]),
                               np.concatenate([d["Rm"] for d in data.values()]))
    report = {t: {"before": in_band(d["err"], d["R"]),
                  "after": in_band(d["err"], s_c**2 * d["Rc"] + s_m**2 * d["Rm"]
                                   + (match_floor_px or 0.0) ** 2 * d["Rf"])}
              for t, d in data.items()}
    return s_c, s_m, report


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m humimic.perception.calibrate",
                                description=__doc__.split("\n\n")[0].replace("\n", " "))
    p.add_argument("scenario", type=Path)
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--duration", type=float, default=None, help="override duration (s)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key, as humimic.run takes it")
    p.add_argument("--out", type=Path, default=None, help="run directory (default: a temp dir)")
    args = p.parse_args(argv)
    try:
        import tempfile

        from humimic.perception.blobs.archive import load_archive
        from humimic.run import run_one
        from humimic.scenario import load_scenario

        scenario = load_scenario(args.scenario, [*args.overrides, "output.plots=false"],
                                 seed=args.seed,
                                 duration=args.duration)
        if scenario.perception is None:
            raise InputError(f"{args.scenario}: no perception section: nothing to calibrate")
        with tempfile.TemporaryDirectory() as tmp:
            out = args.out or Path(tmp)
            run_one(scenario, out, rerun="off", progress=True)
            s_c, s_m, report = calibrate(load_archive(out / "tracking.npz"),
                                         scenario.perception.noise_ref_sigma_px,
                                         scenario.perception.match_floor_px)
    except InputError as err:
        return report_error(err)
    cfg = scenario.perception
    print(f"{scenario.name}, seed {scenario.seed}: fitted pixel_std {s_c:.3f} px, match_std "
          f"{s_m:.3f} px (scenario: {cfg.pixel_std:g}, {cfg.match_std:g})")
    for target, r in report.items():
        (b, bd), (a, ad) = r["before"], r["after"]
        print(f"  {target}: frames with measurement NEES in the 95 % band: {100 * b:.0f} % -> "
              f"{100 * a:.0f} % (bias removed: {100 * bd:.0f} % -> {100 * ad:.0f} %)")
    print(f"perception:\n  pixel_std: {s_c:.3f}\n  match_std: {s_m:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
