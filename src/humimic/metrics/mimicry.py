"""Scores of mimicry against ground truth (pure functions on arrays; SI units). RMSE is
:func:`humimic.maths.stats.rmse`.

* :func:`xcorr_lag` - the delay of a signal behind a reference at the peak of their
  cross-correlation (summed over axes), refined by a parabola through the peak.
* :func:`rms_jerk` - RMS of the third time derivative, estimated with a Savitzky-Golay filter
  (a local polynomial fit; plain third differences would amplify noise by ``1/dt^3``).
* :func:`error_terms` - the total error split into stage terms that add up to it (vectors):
  the estimate's age split into the pipeline's delay, the hold of a fresh estimate and the
  hold of a stale one (a lost target), not one "latency";
* :func:`mse_shares` - each term's share of the total's mean square (shares add up to 1);
* :func:`budget_sums` - their partial sums over a block of rows (a long run scored block by
  block: the whole run's RMS values and shares to rounding).
* :func:`head_motion` - how far the eyes' base moved and turned.
* :func:`image_offsets` - where a target appears relative to an image's centre.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import correlate, savgol_filter

from humimic.maths.stats import rms_of, rmse, sum_squares
from humimic.motion.quat import rotation_angle


def xcorr_lag(reference: np.ndarray, signal: np.ndarray, dt: float,
              max_lag: float = 0.3) -> float:
    """Delay (s) of ``signal`` behind ``reference`` (both ``(N,)`` or ``(N, k)``, sampled every
    ``dt``) at the peak of their normalised cross-correlation: with ``W`` the reference's
    samples at least ``max_lag`` from either end (so every shift overlaps fully),

        rho(l) = sum_axes sum_{t in W} ref(t) sig(t + l) / sqrt(sum_axes sum_{t in W} sig(t + l)^2)

    (means removed) over ``|l| <= max_lag``, refined by a parabola through the peak. By
    Cauchy-Schwarz ``rho`` peaks exactly at the delay of a delayed copy. Positive: the signal
    comes later."""
    ref = np.asarray(reference, float).reshape(len(reference), -1)
    sig = np.asarray(signal, float).reshape(len(signal), -1)
    ref = ref - ref.mean(axis=0)
    sig = sig - sig.mean(axis=0)
    n = len(ref)
    L = min(int(np.ceil(max_lag / dt)), (n - 3) // 2)
    if L < 1:
        return float("nan")
    window = ref[L:n - L]
    num = sum(correlate(sig[:, i], window[:, i], mode="valid", method="fft")
              for i in range(ref.shape[1]))
    energy = np.concatenate([[0.0], np.cumsum(np.sum(sig * sig, axis=1))])
    den = np.sqrt(np.maximum(energy[len(window):] - energy[:-len(window)], 1e-300))
    rho = num / den[:len(num)]
    lags = np.arange(-L, L + 1)
    i = int(np.argmax(rho))
    shift = 0.0
    if 0 < i < len(rho) - 1:
        denom = rho[i - 1] - 2.0 * rho[i] + rho[i + 1]
        if denom < 0.0:
            shift = 0.5 * (rho[i - 1] - rho[i + 1]) / denom
    return float((lags[i] + shift) * dt)


def rms_jerk(p: np.ndarray, dt: float, window_s: float = 0.08) -> float:
    """RMS of ``|d^3 p / dt^3|`` (m/s^3) of ``p`` ``(N, 3)`` sampled every ``dt`` (Savitzky-Golay,
    quintic fit over ``window_s``)."""
    p = np.asarray(p, float)
    w = max(7, int(round(window_s / dt)) | 1)
    if len(p) < w:
        return float("nan")
    j = savgol_filter(p, w, polyorder=5, deriv=3, delta=dt, axis=0, mode="interp")
    return rmse(j)


#: Stage terms of :func:`error_terms`, in pipeline order.
TERMS = ("estimate", "pipeline_delay", "fresh_hold", "stale_hold", "interpolation", "workspace",
         "ik", "servo")

#: A site whose target was lost (no estimate younger than the mimic stage's ``MAX_AGE``) on
#: more than this share of its servo ticks is flagged ``lost_often``: its scores are mostly a
#: held, stale target's.
LOST_OFTEN = 0.25


def lost_status(lost_fraction: float, target: str, max_age: float) -> dict:
    """``{"status": "ok"}``, or ``lost_often`` with the reason when the target was lost (its
    estimate older than ``max_age`` s) on more than :data:`LOST_OFTEN` of the ticks: the
    scores are then mostly a stale target's (:func:`error_terms`' ``stale_hold``)."""
    if lost_fraction <= LOST_OFTEN:
        return {"status": "ok"}
    return {"status": "lost_often",
            "reason": f"{target} lost on {lost_fraction:.0%} of the ticks (no estimate for "
                      f"over {max_age:g} s): the robot held a stale target"}


def error_terms(true_now: np.ndarray, true_photon: np.ndarray, true_ready: np.ndarray,
                true_stale: np.ndarray, est: np.ndarray, cmd_raw: np.ndarray, cmd: np.ndarray,
                ik: np.ndarray, robot: np.ndarray) -> dict[str, np.ndarray]:
    """Split the robot's error ``robot - true_now`` into stage terms that add up to it exactly
    (all ``(N, 3)`` displacements in the robot's mapped space on one time grid). The estimate
    in use has photon time ``t_p`` and was ready at ``t_r``; it goes stale (the target counts
    as lost) at ``t_s = max(t_r, t_p + MAX_AGE)``; ``true_ready``/``true_stale`` are the truth
    at ``t_r`` and at ``min(t_now, t_s)``::

        estimate       = est - true_photon          what control received vs the truth at its
                                                    photon time (perception and filtering)
        pipeline_delay = true_photon - true_ready   the truth's motion while the frame was
                                                    processed (photon to ready: a latency)
        fresh_hold     = true_ready - true_stale    its motion while control held a fresh
                                                    estimate (the wait for the next frame, the
                                                    servo's pickup, the command's tick ahead)
        stale_hold     = true_stale - true_now      its motion since the estimate went stale
                                                    (the target lost; zero while tracked)
        interpolation  = cmd_raw - est              the Cartesian PD (extrapolation cancels
                                                    the estimate's age)
        workspace      = cmd - cmd_raw              clamping into the reachable shell
        ik             = ik - cmd                   the IK's residual (limits, collisions, head)
        servo          = robot - ik                 joint servo tracking

    ``total`` is ``robot - true_now``. The three age terms add up to ``true_photon - true_now``
    (the estimate's age, once called ``latency``). The terms add up to the total at every
    instant, as vectors; their RMS values do not (terms partly cancel, e.g. the PD's lag
    against the age): see :func:`mse_shares` for a split that does.
    """
    return {
        "estimate": est - true_photon,
        "pipeline_delay": true_photon - true_ready,
        "fresh_hold": true_ready - true_stale,
        "stale_hold": true_stale - true_now,
        "interpolation": cmd_raw - est,
        "workspace": cmd - cmd_raw,
        "ik": ik - cmd,
        "servo": robot - ik,
        "total": robot - true_now,
    }


def stale_time(t_now: np.ndarray, t_photon: np.ndarray, t_ready: np.ndarray,
               max_age: float) -> np.ndarray:
    """``min(t_now, max(t_ready, t_photon + max_age))``: where :func:`error_terms`' fresh hold
    ends and its stale hold begins (``t_now`` while the estimate is younger than
    ``max_age``)."""
    return np.minimum(t_now, np.maximum(t_ready, t_photon + max_age))


def mse_shares(terms: dict[str, np.ndarray]) -> dict[str, float]:
    """Each term's share of the total's mean square, ``mean(term . total) / mean(|total|^2)``
    (over rows where every term is finite). Because the terms add up to the total, the shares
    add up to 1 exactly; a negative share is a term that cancels others. NaN when the total is
    zero or there are no rows."""
    return budget_from_sums(budget_sums(terms))[1]


def budget_sums(terms: dict[str, np.ndarray]) -> dict[str, float]:
    """Partial sums of :func:`error_terms`' output over a block of rows, from which
    :func:`budget_from_sums` gives each term's RMS, :func:`mse_shares` and the largest error:
    sums over blocks (:func:`add_budget_sums`) give the whole run's values to rounding, without
    its whole columns. Keys: ``sq:<name>``/``n:<name>`` (``sum_squares`` of each term and the
    total), ``dot:<term>`` (``sum term . total``) and ``ms`` (``sum |total|^2``) over the
    ``ok`` rows where every term is finite, ``max`` (the largest ``|total|``; NaN if any row is
    NaN, as ``np.max``; -inf for no rows)."""
    total = np.asarray(terms["total"], float)
    out: dict[str, float] = {}
    for name in (*TERMS, "total"):
        out[f"sq:{name}"], out[f"n:{name}"] = sum_squares(terms[name])
    ok = np.all(np.isfinite(total), axis=1)
    for name in TERMS:
        ok &= np.all(np.isfinite(terms[name]), axis=1)
    for name in TERMS:
        out[f"dot:{name}"] = float(np.sum(terms[name][ok] * total[ok]))
    out["ms"], out["ok"] = float(np.sum(total[ok] ** 2)), int(ok.sum())
    out["max"] = float(np.max(np.linalg.norm(total, axis=1))) if len(total) else -np.inf
    return out


def add_budget_sums(a: dict[str, float] | None, b: dict[str, float]) -> dict[str, float]:
    """:func:`budget_sums` of two blocks of rows together (``a`` None: ``b``)."""
    if a is None:
        return dict(b)
    return {k: float(np.max([a[k], b[k]])) if k == "max" else a[k] + b[k] for k in a}


def budget_from_sums(sums: dict[str, float]) -> tuple[dict[str, float], dict[str, float],
                                                       float]:
    """``(RMS of each term and of the total (m), each term's share of the total's mean square,
    largest |total| (m))`` from :func:`budget_sums` (shares NaN when the total is zero or no
    row is finite in every term; the largest error NaN for no rows)."""
    rms = {name: rms_of(sums[f"sq:{name}"], sums[f"n:{name}"]) for name in (*TERMS, "total")}
    ms = sums["ms"]
    if sums["ok"] == 0 or ms == 0.0:
        shares = dict.fromkeys(TERMS, float("nan"))
    else:
        shares = {name: sums[f"dot:{name}"] / ms for name in TERMS}
    top = sums["max"]
    return rms, shares, (top if top != -np.inf else float("nan"))


def head_motion(p: np.ndarray, R: np.ndarray) -> tuple[float, float]:
    """Largest displacement (m) and rotation (rad) of a frame from its first sample
    (``p (N, 3)``, ``R (N, 3, 3)``)."""
    if len(p) == 0:
        return 0.0, 0.0
    dp = np.linalg.norm(p - p[0], axis=1)
    dR = np.einsum("ji,njk->nik", R[0], R)  # R0^T R
    return float(dp.max()), float(rotation_angle(dR).max())


def image_offsets(p_cam: np.ndarray, fx: float, fy: float, width: int,
                  height: int) -> np.ndarray:
    """Distance (fraction of the image width) of camera-frame points ``(N, 3)`` (OpenCV axes)
    from the principal point; points behind the camera give ``inf``."""
    p = np.asarray(p_cam, float)
    z = p[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        du = np.where(z > 0, fx * p[:, 0] / z, np.inf)
        dv = np.where(z > 0, fy * p[:, 1] / z, np.inf)
    return np.hypot(du, dv) / width


def summary_stats(x: np.ndarray) -> dict[str, float]:
    """mean, 95th percentile and max of finite values (None when there are none)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return {"mean": None, "p95": None, "max": None}
    return {"mean": float(x.mean()), "p95": float(np.percentile(x, 95)), "max": float(x.max())}
