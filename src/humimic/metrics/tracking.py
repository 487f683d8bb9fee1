"""Tracking scores: perception's raw 3-D measurements and the filter's estimates vs ground truth.

All errors are in the robot base frame, against the true site position / velocity /
acceleration at the frame's *photon* time. Lengths are reported in mm (the paper's unit).
Undefined scores (no measurement, no estimate) are ``None`` (JSON null), never NaN.

``tracking.<target>``:

* ``frames``, ``measured_frames``;
* ``detection_rate``: frames with a valid 3-D measurement / frames from the first one on
  (0 if never measured); ``detection_rate_all``: the same over all frames;
* ``time_to_first_detection_s``: photon time of the first valid measurement since the first
  frame (None if never); ``losses`` / ``reacquisitions``: changes tracking -> lost and
  lost -> tracking of the target's state;
* ``pixel_rmse``: blob centre vs the projected true position, both eyes pooled, over the frames
  the blob carried the target's name with a sure identity (px);
* ``raw_rmse_mm``, ``raw_bias_mm`` and ``raw_std_mm`` (per axis x, y, z: mean and standard
  deviation of the error; for a static target the std is that of the measurements), and
  ``raw_nees`` (mean of e^T R^-1 e, 3 when R is right);
* ``filtered_rmse_mm``, ``filtered_bias_mm``, ``filtered_std_mm``, ``filtered_nees``,
  ``vel_rmse_mm_s``, ``vel_bias_mm_s``, ``vel_std_mm_s``, ``acc_rmse_mm_s2``,
  ``acc_bias_mm_s2``, ``acc_std_mm_s2``: the filter's estimates at the frames it fused a
  measurement, at least ``filter_settle_s`` after its (re)initialisation (its start-up
  transient, when v and a start from 0 with huge variances, is left out);
* ``predicted_frames``, ``predicted_rmse_mm``: the estimates published for frames without a
  measurement (prediction only, up to the filter's ``max_gap``).
"""

from __future__ import annotations

import math

import numpy as np

from humimic.perception.blobs.record import STATE_CODE

MM = 1e3
#: Start-up transient of the filter excluded from its scores (s).
FILTER_SETTLE_S = 0.5


def num(x) -> float | None:
    """A finite float, or None."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def nums(a) -> list[float | None]:
    return [num(v) for v in np.asarray(a, float).ravel()]


def rmse(err: np.ndarray) -> float | None:
    """Root mean squared norm of error vectors ``(N, d)`` (None for N = 0)."""
    err = np.asarray(err, float)
    if len(err) == 0:
        return None
    return num(np.sqrt(np.mean(np.sum(err * err, axis=-1))))


def axis_stats(err: np.ndarray, scale: float = 1.0) -> tuple[list, list]:
    """Per-axis mean and (population) standard deviation of ``err (N, 3)``, times ``scale``."""
    err = np.asarray(err, float)
    if len(err) == 0:
        return [None] * err.shape[-1], [None] * err.shape[-1]
    return nums(scale * err.mean(axis=0)), nums(scale * err.std(axis=0))


def mean_nees(err: np.ndarray, cov: np.ndarray) -> float | None:
    """Mean of ``e^T C^-1 e`` over samples (None if none)."""
    if len(err) == 0:
        return None
    sol = np.linalg.solve(cov, err[..., None])[..., 0]
    return num(np.mean(np.einsum("ni,ni->n", err, sol)))


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
        "detection_rate_all": float(ok.mean()) if n else 0.0,
        "time_to_first_detection_s": None if first is None else num(t[first] - t[0]),
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
    px = rmse(pixel_errors(pa, i, p_true))
    return {"raw_rmse_mm": None if r is None else r * MM, "raw_bias_mm": bias,
            "raw_std_mm": std, "raw_nees": mean_nees(err, pa.R_base[ok, i]),
            "pixel_rmse": px}


def filtered_scores(fa, j: int, p_true, v_true, a_true, settle_s: float = FILTER_SETTLE_S
                    ) -> dict:
    """Scores of the filter's estimates of target ``j`` (truth arrays at the frames)."""
    use = fa.valid[:, j] & fa.measured[:, j] & (fa.since_init[:, j] >= settle_s)
    x = fa.x[use, j]
    pred = fa.valid[:, j] & ~fa.measured[:, j]
    r = rmse(fa.x[pred, j, 0:3] - p_true[pred])
    out: dict = {"filter_settle_s": settle_s, "estimated_frames": int(fa.valid[:, j].sum()),
                 "scored_estimates": int(use.sum()), "predicted_frames": int(pred.sum()),
                 "predicted_rmse_mm": None if r is None else r * MM}
    for key, sl, truth, unit in (("filtered", slice(0, 3), p_true, ""),
                                 ("vel", slice(3, 6), v_true, "_s"),
                                 ("acc", slice(6, 9), a_true, "_s2")):
        err = x[:, sl] - truth[use]
        bias, std = axis_stats(err, MM)
        r = rmse(err)
        out[f"{key}_rmse_mm{unit}"] = None if r is None else r * MM
        out[f"{key}_bias_mm{unit}"] = bias
        out[f"{key}_std_mm{unit}"] = std
    out["filtered_nees"] = mean_nees(x[:, 0:3] - p_true[use], fa.P[use, j, 0:3, 0:3])
    return out


def target_scores(target: str, pa, fa, p_true: np.ndarray, truth_filter=None,
                  settle_s: float = FILTER_SETTLE_S) -> dict:
    """Every ``tracking.<target>`` score (``fa`` None: perception only). ``p_true``: true
    positions at the perception frames; ``truth_filter``: true (p, v, a) at the filter's."""
    i = pa.index(target)
    out = detection_stats(pa.t, pa.ok[:, i], pa.state[:, i])
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
