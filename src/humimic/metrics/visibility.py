"""Detection scores against the visibility ground truth (:mod:`humimic.sensors.visibility`).

``tracking.<target>`` gains:

* ``visible_fraction``: perception frames in which the target is visible to both eyes (in view,
  at least half unoccluded; stereo needs both);
* ``detection_rate``: frames with a valid 3-D measurement / visible frames, counted from the
  end of detection's phase one (``warmup_s``: the tracker is blind by design before it);
  ``None`` when the target is never visible then;
* ``false_detection_rate``: blob reports (per eye; a report is a blob carrying the target's
  name while perception vouches for it, i.e. its identity margin is met: an unsure name is not
  published) that are false / all blob reports: the
  target is hidden in that eye (out of view or less than :data:`HIDDEN_FRACTION` unoccluded),
  or the blob is on something else (the target's true position lies outside the blob's
  :data:`OFF_TARGET_SIGMA`-sigma ellipse); ``false_detections``: frames with one;
* ``median_size_px``, ``median_unoccluded``: over the frames the target is in view of both eyes;
* ``verdict`` (``ok`` / ``poor``, or ``unscored`` for a run that ended in detection's phase one,
  the tracker blind by design: ``--duration`` under ``perception.detection.period``) and
  ``cause``: a target detected on less than
  :data:`POOR_RATE` of its visible frames, or never, is ``poor``, with its likely cause:
  ``out of view``, ``occluded``, ``identity unsure: ...`` (blobs tracked in both eyes, their
  name not sure), ``too small: N px`` or ``colour model mismatch``; so is one
  with more than :data:`FALSE_RATE` of its reports false (``false detections: N %``).
"""

from __future__ import annotations

import numpy as np

from humimic.maths.stats import finite_or_none

HIDDEN_FRACTION = 0.1
"""A target less unoccluded than this (or out of view) is hidden."""
OFF_TARGET_SIGMA = 3.0
"""A blob whose ellipse (this many standard deviations) misses the true position is false."""
POOR_RATE = 0.5
"""A target detected on fewer of its visible frames is flagged (verdict ``poor``)."""
FALSE_RATE = 0.1
"""A target more of whose blob reports than this are false is flagged too."""
SMALL_PX = 10.0
"""A poorly detected target smaller than this (median diameter, px) is named too small to be
detected (Ude's threshold (eq. 9) is a fraction of the largest blobs' colour sums). Measured
in ude_wave_tracking (wide cameras, 320x240): with ``perception.detection.refine_fit`` (on by
default) the hanging hand is found at 7-8 px (1.2-1.5 m; without it, the right hand hanging
at 8 px never was), at 5 px (2.0 m) never; a poorly detected target under 10 px is most
likely too small."""


UNSURE_SHARE = 0.5
"""A poorly detected target whose missed visible frames had both eyes' blobs named but unsure
at least this often is named ``identity unsure`` (not a colour or size problem: e.g. a head
2.2 m away whose blob reads a sigma radius between a head's least and a hand's largest, which
the identity rules cannot name; before, ``colour model mismatch``)."""


def eye_visibility(vis, t: np.ndarray, cams: tuple[str, str], target: str):
    """``(visible, hidden, in_view, unoccluded, size)``, each ``(F, 2)``: per perception frame
    (photon times ``t``) and eye."""
    k = vis.at(t)
    c = [vis.camera(name) for name in cams]
    j = vis.target(target)
    in_view = vis.in_view[k][:, c, j]
    unocc = vis.unoccluded[k][:, c, j]
    return (vis.visible[k][:, c, j], ~in_view | (unocc < HIDDEN_FRACTION), in_view, unocc,
            vis.size_px[k][:, c, j])


def off_target(centre: np.ndarray, cov: np.ndarray, uv_true: np.ndarray,
               k_sigma: float = OFF_TARGET_SIGMA) -> np.ndarray:
    """Whether ``uv_true`` ``(N, 2)`` lies outside blobs (``centre (N, 2)``, shape ``cov
    (N, 2, 2)``) at ``k_sigma`` standard deviations (squared Mahalanobis distance)."""
    d = uv_true - centre
    m2 = np.einsum("ni,nij,nj->n", d, np.linalg.inv(cov), d)
    return m2 > k_sigma**2


def cause(visible_fraction: float, median_unoccluded: float | None,
          median_size: float | None, unsure_share: float = 0.0) -> str:
    """The likely reason a target was detected on few of its visible frames;
    ``unsure_share``: of its visible frames without a measurement, the share in which both
    eyes tracked a blob of that name but perception was not sure of the name (its identity
    margin not met), so did not measure it."""
    if median_unoccluded is None:
        return "out of view"
    if visible_fraction == 0.0:
        return "occluded"
    if unsure_share >= UNSURE_SHARE:
        return (f"identity unsure: tracked in both eyes, name not sure on "
                f"{100 * unsure_share:.0f} % of the missed frames")
    if median_size is not None and median_size < SMALL_PX:
        return f"too small: {median_size:.0f} px"
    return "colour model mismatch"


def visibility_scores(pa, i: int, target: str, vis, p_true: np.ndarray, warmup_s: float
                      ) -> dict:
    """The scores above for target ``i`` of the perception arrays ``pa`` (``p_true``: its true
    positions at the frames)."""
    visible_eye, hidden_eye, in_view, unocc, size = eye_visibility(vis, pa.t, pa.cameras,
                                                                   target)
    visible = visible_eye.all(axis=1)
    ok = pa.ok[:, i]
    after = (pa.t - pa.t[0] >= warmup_s - 1e-9) if len(pa.t) else np.zeros(0, bool)
    scored = visible & after
    seen = pa.seen[:, i] & (pa.confirmed[:, i] & after)[:, None]
    false = seen & hidden_eye
    for eye in (0, 1):
        frames = np.flatnonzero(seen[:, eye] & ~hidden_eye[:, eye])
        if len(frames):
            uv = np.array([pa.camera(f, eye).project_base(p_true[f]) for f in frames.tolist()])
            false[frames, eye] = off_target(pa.centre[frames, i, eye], pa.cov[frames, i, eye],
                                            uv)
    in_view = in_view.all(axis=1)
    med_unocc = finite_or_none(np.median(unocc[in_view].min(axis=1))) if in_view.any() \
        else None
    med_size = finite_or_none(np.median(size[in_view].min(axis=1))) if in_view.any() \
        else None
    rate = float(ok[scored].mean()) if scored.any() else None
    visible_fraction = float(visible.mean()) if len(visible) else 0.0
    false_rate = float(false.sum() / seen.sum()) if seen.any() else 0.0
    poor = rate is None or rate < POOR_RATE or false_rate > FALSE_RATE
    missed = scored & ~ok
    unsure = missed & pa.seen[:, i].all(axis=1) & ~pa.confirmed[:, i]
    unsure_share = float(unsure.sum() / missed.sum()) if missed.any() else 0.0
    why = (f"false detections: {100 * false_rate:.0f} % of reports"
           if false_rate > FALSE_RATE else cause(visible_fraction, med_unocc, med_size,
                                                 unsure_share))
    if not after.any():  # nothing to judge: not a poor detection
        poor, why = False, f"the run ended in detection's phase one, its first {warmup_s:g} s"
    return {
        "visible_fraction": visible_fraction,
        "visible_frames": int(visible.sum()),
        "detection_rate": rate,
        "false_detection_rate": false_rate,
        "false_detections": int(false.any(axis=1).sum()),
        "median_size_px": med_size,
        "median_unoccluded": med_unocc,
        "verdict": "unscored" if not after.any() else "poor" if poor else "ok",
        "cause": why if poor or not after.any() else None,
    }
