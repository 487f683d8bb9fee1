"""The ``tracking`` report: scores, plots, rerun error series and the record archive of
perception + filter.

A stage with no inputs: it reads the perception and filter records after the run and the
ground truth at the frames' photon times (see :mod:`humimic.metrics.tracking` for the scores).
``archive(out_dir)`` writes ``tracking.npz`` (:mod:`humimic.perception.blobs.archive`), plots or
not; ``plots(out_dir)`` writes ``tracking_<target>_error.png`` and ``tracking_<target>_pva.png``;
``log(rlog)`` logs the error series to rerun.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from humimic.metrics.tracking import FILTER_SETTLE_S, stereo_failures, target_scores
from humimic.perception.blobs.archive import save_archive
from humimic.perception.blobs.plots import plot_pva, plot_tracking_errors
from humimic.pipeline.stage import Stage
from humimic.viz.entities import visibility_entity
from humimic.viz.plots import MAX_POINTS
from humimic.viz.rerun_log import AXIS_RGB, SERIES


class TrackingReport(Stage):
    name = "tracking"

    def __init__(self, targets: list[str], perception_record, filter_record, gt,
                 settle_s: float = FILTER_SETTLE_S, visibility=None, warmup_s: float = 0.0):
        self.targets = list(targets)
        self.perception_record, self.filter_record = perception_record, filter_record
        self.gt, self.settle_s = gt, settle_s
        self.visibility, self.warmup_s = visibility, warmup_s
        """:class:`~humimic.sensors.visibility.Visibility` of the eyes (None: no visibility
        scores) and detection's phase one (s), which detection rates leave out."""

    def arrays(self, target: str | None = None, cov_block: int = 9):
        """``(PerceptionArrays, FilterArrays | None)`` of the run so far; with ``target``,
        of that target alone (what a long run gathers at a time: one target's columns); the
        filter's covariances cut to their leading ``cov_block`` block (the series and plots
        show the position's 3 x 3)."""
        one = None if target is None else [target]
        pa = self.perception_record.arrays(one)
        fa = None
        if self.filter_record is not None:
            fa = self.filter_record.arrays(
                None if target is None else [t for t in one if t in self.filter_record.targets],
                cov_block)
        return pa, fa

    def truth(self, t: np.ndarray, target: str):
        """True (p, v, a) of ``target`` in the base frame at photon times ``t``: (F, 3) each."""
        if len(t) == 0:
            z = np.zeros((0, 3))
            return z, z, z
        k = np.atleast_1d(self.gt.index_of(t))
        return (self.gt.p_base(target)[k], self.gt.v_base(target)[k],
                self.gt.a_base(target)[k])

    def metrics(self) -> dict:
        """``tracking.<target>`` scores."""
        vis = self.visibility.arrays() if self.visibility is not None else None
        out = {}
        for target in self.targets:
            pa, fa = self.arrays(target)
            p, _, _ = self.truth(pa.t, target)
            scores = target_scores(target, pa, fa, p,
                                   self.truth(fa.t, target) if fa is not None else None,
                                   self.settle_s, vis, self.warmup_s)
            scores["stereo_failures"] = stereo_failures(pa, pa.index(target))
            out[target] = scores
        return {"tracking": out}

    def log(self, rlog) -> None:
        """Raw and filtered error series (and the filter's 2-sigma) per target, to rerun."""
        if rlog is None or not rlog.enabled:
            return
        for target in self.targets:
            pa, fa = self.arrays(target, cov_block=3)
            self._log_series(rlog, target, pa, fa, self.truth(pa.t, target)[0])
        if self.visibility is not None:
            log_visibility(rlog, self.visibility.arrays(), self.targets)

    def archive(self, out_dir) -> list:
        """``tracking.npz``: every measurement and estimate with the truth at their times."""
        prec, frec = self.perception_record, self.filter_record
        t_p = _times(prec)
        t_f = _times(frec) if frec is not None else None
        return [save_archive(  # the records' columns written batch by batch
            Path(out_dir) / "tracking.npz", prec, frec,
            {t: self.truth(t_p, t) for t in self.targets},
            {t: self.truth(t_f, t) for t in self.targets} if frec is not None else {},
            self.visibility.arrays() if self.visibility is not None else None)]

    def _log_series(self, rlog, target, pa, fa, p) -> None:
        i = pa.index(target)
        ok = pa.ok[:, i]
        root = f"{SERIES}/tracking/{target}"
        if ok.any():
            rlog.log_series(f"{root}/raw_error_mm", pa.t[ok], 1e3 * (pa.p_base[ok, i] - p[ok]),
                            names=[f"raw {a} error (mm)" for a in "xyz"],
                            colors=[tuple(128 + c // 2 for c in rgb) for rgb in AXIS_RGB],
                            widths=[1.0] * 3)
        if fa is not None:
            j = fa.targets.index(target)
            use = fa.valid[:, j]
            pf, _, _ = self.truth(fa.t, target)
            if use.any():
                rlog.log_series(f"{root}/filtered_error_mm", fa.t[use],
                                1e3 * (fa.x[use, j, :3] - pf[use]),
                                names=[f"filtered {a} error (mm)" for a in "xyz"],
                                colors=list(AXIS_RGB), widths=[2.0] * 3)
                sig = 1e3 * np.sqrt(np.diagonal(fa.P[use, j, :3, :3], axis1=-2, axis2=-1))
                rlog.log_series(f"{root}/filter_2sigma_mm", fa.t[use],
                                np.concatenate([2.0 * sig, -2.0 * sig], axis=1),
                                names=[f"{s}2σ {a} (mm)" for s in "+−" for a in "xyz"],
                                colors=list(AXIS_RGB) * 2, widths=[0.75] * 6)

    def plots(self, out_dir) -> list:
        out = Path(out_dir)
        paths = []
        for target in self.targets:
            pa, fa = self.arrays(target, cov_block=3)
            i = pa.index(target)
            p, _, _ = self.truth(pa.t, target)
            ok = pa.ok[:, i]
            t_est = np.zeros(0)
            est_err = sig = x = np.zeros((0, 3))
            if fa is not None:
                j = fa.targets.index(target)
                use = fa.valid[:, j]
                t_est, x = fa.t[use], fa.x[use, j]
                est_err = 1e3 * (x[:, :3] - self.truth(fa.t, target)[0][use])
                sig = 1e3 * np.sqrt(np.diagonal(fa.P[use, j, :3, :3], axis1=-2, axis2=-1))
            paths.append(plot_tracking_errors(
                out / f"tracking_{target}_error.png", target, pa.t[ok],
                1e3 * (pa.p_base[ok, i] - p[ok]), t_est, est_err, sig))
            if fa is not None and len(pa.t):
                k = np.arange(self.gt.index_of(pa.t[0]), self.gt.index_of(pa.t[-1]) + 1)
                k = k[::max(1, -(-len(k) // MAX_POINTS))]  # what the plot draws
                gt_t = self.gt.t[k]
                paths.append(plot_pva(out / f"tracking_{target}_pva.png", target, t_est, x,
                                      gt_t, self.gt.p_base(target)[k],
                                      self.gt.v_base(target)[k], self.gt.a_base(target)[k]))
        return paths


def _times(record) -> np.ndarray:
    """A record's frame times (its first column) alone: ``record.arrays().t``."""
    if not len(record.rows):
        return np.zeros(0)
    return record.rows.columns({0: lambda c: c})[0].astype(float)


def log_visibility(rlog, vis, targets: list[str]) -> None:
    """The eyes' visibility ground truth of ``targets`` as rerun series: unoccluded fraction
    (0 out of view) and visible size (px), one line per eye camera."""
    if not len(vis.t):
        return
    unocc, size = vis.unoccluded, vis.size_px
    for target in targets:
        if target not in vis.targets:
            continue
        j = vis.target(target)
        for name, values, unit in (("unoccluded", unocc, ""), ("size_px", size, " (px)")):
            rlog.log_series(visibility_entity(target, name), vis.t, values[:, :, j],
                            names=[f"{cam} {name.replace('_px', '')}{unit}"
                                   for cam in vis.cameras])
