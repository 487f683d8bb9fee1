"""Tracking scores: perception's raw 3-D measurements and the filter's estimates vs ground truth.

All errors are in the robot base frame, against the true site position / velocity /
acceleration at the frame's *photon* time. Lengths are reported in mm (the paper's unit).
Undefined scores (no measurement, no estimate) are ``None`` (JSON null), never NaN.

``tracking.<target>``:

* ``frames``, ``measured_frames``;
* ``detection_rate``: frames with a valid 3-D measurement / frames the target is visible
  (:mod:`humimic.metrics.visibility`, with ``visible_fraction``, ``false_detection_rate`` and a
  ``verdict``; without visibility ground truth, the next figure);
  ``detection_rate_from_first``: the same over the frames from the first measurement on (0 if
  never measured); ``detection_rate_all``: over all frames;
* ``time_to_first_detection_s``: photon time of the first valid measurement since the first
  frame (None if never); ``losses`` / ``reacquisitions``: changes tracking -> lost and
  lost -> tracking of the target's state;
* ``pixel_rmse``: blob centre vs the projected true position, both eyes pooled, over the frames
  the blob carried the target's name with a sure identity (px);
* ``raw_rmse_mm``, ``raw_bias_mm`` and ``raw_std_mm`` (per axis x, y, z: mean and standard
  deviation of the error; for a static target the std is that of the measurements);
  ``raw_bias_share``: the bias's share of the mean square error (``|mean|^2 / RMSE^2``) and
  ``biased``: true when it exceeds :data:`BIAS_SHARE` (e.g. the head: stereo sees its front
  surface, the truth is its centre);
* NEES (normalised estimation error squared, ``e^T P^-1 e``: the squared error in units of
  the covariance the stage reported; chi-square with as many degrees of freedom as the key says
  when the covariance is right): ``raw_nees_pos3`` (measurement vs its R, 3 dof; mean over
  frames), ``raw_nees_pos3_in_band`` (fraction of frames inside the two-sided 95 % chi-square
  band), ``raw_nees_pos3_debiased_in_band`` (the same with the mean error removed: whether R
  describes the noise, bias aside);
* ``filtered_rmse_mm``, ``filtered_bias_mm``, ``filtered_std_mm``, ``vel_rmse_mm_s``,
  ``vel_bias_mm_s``, ``vel_std_mm_s``, ``acc_rmse_mm_s2``, ``acc_bias_mm_s2``,
  ``acc_std_mm_s2``, ``filtered_nees_pos3`` / ``filtered_nees_pos3_in_band`` (position
  block of P) and ``filtered_nees_pva9`` / ``filtered_nees_pva9_in_band`` (the whole state):
  the filter's estimates at the frames it fused a measurement, at least ``filter_settle_s``
  after its (re)initialisation (its start-up transient, when v and a start from 0 with huge
  variances, is left out);
* ``predicted_frames``, ``predicted_rmse_mm``: the estimates published for frames without a
  fused measurement (prediction only, up to the filter's ``max_gap``; a measurement the
  filter's innovation gate rejected leaves its frame predicted).
"""

from __future__ import annotations

import numpy as np

from humimic.maths.stats import (
    finite_or_none,
    fraction_above_band,
    fraction_in_band,
    nees,
    rmse,
)
from humimic.metrics import mm
from humimic.metrics.visibility import visibility_scores
from humimic.perception.blobs.record import STATE_CODE

MM = 1e3
#: Start-up transient of the filter excluded from its scores (s); the report page uses it too.
FILTER_SETTLE_S = 0.5
#: A target is ``biased`` when its mean error makes up more than this share of its mean square
#: error (the bias outweighs the noise).
BIAS_SHARE = 0.5


def nums(a) -> list[float | None]:
    return [finite_or_none(v) for v in np.asarray(a, float).ravel()]


def nees_scores(prefix: str, err: np.ndarray, cov: np.ndarray, debiased: bool = False
                ) -> dict:
    """``<prefix>`` (mean NEES) and ``<prefix>_in_band`` (fraction of samples inside the 95 %
    chi-square band, dof = ``err.shape[1]``); with ``debiased`` also ``<prefix>_debiased_in_band``
    (the mean error removed first) and ``<prefix>_debiased_above_band`` (the fraction above the
    band: errors larger than the covariance says; 0.025 when consistent). None when there are
    no samples."""
    dof = err.shape[1]
    values = nees(err, cov) if len(err) else np.zeros(0)
    out = {prefix: finite_or_none(np.nanmean(values)) if len(values) else None,
           f"{prefix}_in_band": finite_or_none(fraction_in_band(values, dof))}
    if debiased:
        d = nees(err - err.mean(axis=0), cov) if len(err) else np.zeros(0)
        out[f"{prefix}_debiased_in_band"] = finite_or_none(fraction_in_band(d, dof))
        out[f"{prefix}_debiased_above_band"] = finite_or_none(fraction_above_band(d, dof))
    return out


def axis_stats(err: np.ndarray, scale: float = 1.0) -> tuple[list, list]:
    """Per-axis mean and (population) standard deviation of ``err (N, 3)``, times ``scale``."""
    err = np.asarray(err, float)
    if len(err) == 0:
        return [None] * err.shape[-1], [None] * err.shape[-1]
    return nums(scale * err.mean(axis=0)), nums(scale * err.std(axis=0))


def detection_stats(t: np.ndarray, ok: np.ndarray, state: np.ndarray) -> dict:
    """Detection scores of one target from per-frame validity ``ok`` and state codes."""
    n = len(t)
    first = int(np.argmax(ok)) if ok.any() else None
    tracking, lost = STATE_CODE["tracking"], STATE_CODE["lost"]
    prev, cur = state[:-1], state[1:]
    return {
        "frames": n,
        "measured_frames": int(ok.sum()),
        "detection_rate": 0.0 if first is None else float(ok[first:].mean()),
        "detection_rate_from_first": 0.0 if first is None else float(ok[first:].mean()),
        "detection_rate_all": float(ok.mean()) if n else 0.0,
        "time_to_first_detection_s": None if first is None else finite_or_none(t[first] - t[0]),
        "losses": int(np.sum((prev == tracking) & (cur == lost))),
        "reacquisitions": int(np.sum((prev == lost) & (cur == tracking))),
    }


def pixel_errors(pa, i: int, p_true: np.ndarray) -> np.ndarray:
    """Blob centre minus projected true position (px) over every frame and eye in which a blob
    carried target ``i``'s name, sure of it (``confirmed``): ``(M, 2)``."""
    out = []
    for eye in (0, 1):
        frames = np.flatnonzero(pa.seen[:, i, eye] & pa.confirmed[:, i])
        for f in frames.tolist():
            uv = pa.camera(f, eye).project_base(p_true[f])
            out.append(pa.centre[f, i, eye] - uv)
    return np.array(out).reshape(-1, 2)


def raw_scores(pa, i: int, p_true: np.ndarray) -> dict:
    """Scores of the raw measurements of target ``i`` (``p_true``: (F, 3) at the frames)."""
    ok = pa.ok[:, i]
    err = pa.p_base[ok, i] - p_true[ok]
    bias, std = axis_stats(err, MM)
    r = rmse(err)
    share = finite_or_none(np.sum(err.mean(axis=0) ** 2) / r**2) if len(err) and r > 0 \
        else None
    return {"raw_rmse_mm": mm(r), "raw_bias_mm": bias, "raw_std_mm": std,
            "raw_bias_share": share, "biased": share is not None and share > BIAS_SHARE,
            **nees_scores("raw_nees_pos3", err, pa.R_base[ok, i], debiased=True),
            "pixel_rmse": finite_or_none(rmse(pixel_errors(pa, i, p_true)))}


def filtered_scores(fa, j: int, p_true, v_true, a_true, settle_s: float = FILTER_SETTLE_S
                    ) -> dict:
    """Scores of the filter's estimates of target ``j`` (truth arrays at the frames)."""
    use = fa.valid[:, j] & fa.measured[:, j] & (fa.since_init[:, j] >= settle_s)
    x = fa.x[use, j]
    pred = fa.valid[:, j] & ~fa.measured[:, j]
    out: dict = {"filter_settle_s": settle_s, "estimated_frames": int(fa.valid[:, j].sum()),
                 "scored_estimates": int(use.sum()), "predicted_frames": int(pred.sum()),
                 "predicted_rmse_mm": mm(rmse(fa.x[pred, j, 0:3] - p_true[pred]))}
    for key, sl, truth, unit in (("filtered", slice(0, 3), p_true, ""),
                                 ("vel", slice(3, 6), v_true, "_s"),
                                 ("acc", slice(6, 9), a_true, "_s2")):
        err = x[:, sl] - truth[use]
        bias, std = axis_stats(err, MM)
        out[f"{key}_rmse_mm{unit}"] = mm(rmse(err))
        out[f"{key}_bias_mm{unit}"] = bias
        out[f"{key}_std_mm{unit}"] = std
    err = x - np.concatenate([p_true[use], v_true[use], a_true[use]], axis=1)
    out.update(nees_scores("filtered_nees_pos3", err[:, 0:3], fa.P[use, j, 0:3, 0:3]))
    out.update(nees_scores("filtered_nees_pva9", err, fa.P[use, j]))
    return out


def target_scores(target: str, pa, fa, p_true: np.ndarray, truth_filter=None,
                  settle_s: float = FILTER_SETTLE_S, visibility=None, warmup_s: float = 0.0
                  ) -> dict:
    """Every ``tracking.<target>`` score (``fa`` None: perception only). ``p_true``: true
    positions at the perception frames; ``truth_filter``: true (p, v, a) at the filter's;
    ``visibility``: :class:`~humimic.sensors.visibility.VisibilityArrays` (None: no
    visibility scores), ``warmup_s``: detection's phase one."""
    i = pa.index(target)
    out = detection_stats(pa.t, pa.ok[:, i], pa.state[:, i])
    if visibility is not None and len(visibility.t) and len(pa.t):
        out.update(visibility_scores(pa, i, target, visibility, p_true, warmup_s))
    out.update(raw_scores(pa, i, p_true))
    if fa is not None and target in fa.targets:
        out.update(filtered_scores(fa, fa.targets.index(target), *truth_filter,
                                   settle_s=settle_s))
    return out


def stereo_failures(pa, i: int) -> dict[str, int]:
    """How often each reason stopped target ``i``'s 3-D measurement (frames it was seen)."""
    reasons, counts = np.unique(pa.reason[:, i].astype(str), return_counts=True)
    return {str(r): int(c) for r, c in zip(reasons, counts, strict=True)
            if r not in ("", "not_seen")}
