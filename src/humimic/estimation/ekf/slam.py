"""Monocular EKF SLAM with inertial measurements: the estimator of Sugiyama & Miura sec. III.

State (Sugiyama eq. 1): the 19-number interface (:mod:`.motion_model`) followed by the map,
one block per feature: 6 numbers while it is an inverse-depth point, 3 once converted to XYZ
(:mod:`.inverse_depth`). Known features (the screen corners) are XYZ blocks with zero
covariance: they fix the frame and the scale.

The filter advances to each measurement's time stamp (multi-rate, as Armesto et al.): the
head IMU's orientation and acceleration at their own rate (eqs. 6-7), the camera's features
once per frame (eqs. 8-9). The image side (detection, patch matching) lives in
:mod:`.frontend`; this class only sees pixels: :meth:`SlamFilter.predict_features` says
where each map feature should appear and how uncertain that is (the search ellipses), and
:meth:`SlamFilter.update_features` fuses the matches.
"""

from __future__ import annotations

import math

import numpy as np

from humimic.estimation.ekf import inverse_depth as idp
from humimic.estimation.ekf import motion_model as mm
from humimic.estimation.ekf import state_blocks as sb
from humimic.estimation.ekf import update as up
from humimic.estimation.ekf.compressed import Deferred
from humimic.estimation.ekf.quaternion import align_sign, d_normalize
from humimic.estimation.ekf.slam_types import (
    DEFAULT_SLAM_PARAMS,
    POSE_COLS,
    FeaturePrediction,
    MapFeature,
    SlamParams,
)
from humimic.sensors.camera_model import Intrinsics

__all__ = ["POSE_COLS", "FeaturePrediction", "MapFeature", "SlamFilter", "SlamParams"]

class SlamFilter:
    """The EKF: state, covariance, map bookkeeping. Times in seconds, pixels undistorted."""

    def __init__(self, t0: float, x0: np.ndarray, P0: np.ndarray, intr: Intrinsics,
                 R_cv_I: np.ndarray, params: SlamParams = DEFAULT_SLAM_PARAMS):
        """``x0, P0`` the interface's state and covariance at ``t0``; ``intr`` the camera
        (its undistorted image is what :meth:`predict_features` predicts); ``R_cv_I`` the
        rotation from the interface frame I to the camera's OpenCV axes."""
        self.t = float(t0)
        self._x = np.array(x0, float)
        self._P = np.array(P0, float)
        # The IMU steps touch only the interface; their effect on the map is deferred and
        # applied before anything reads or changes the map (:mod:`.compressed`).
        self._deferred = Deferred(mm.DIM)
        self._orient_noise: tuple[np.ndarray, np.ndarray] | None = None
        self.intr = intr.pinhole()
        self.R_cv_I = np.asarray(R_cv_I, float)
        self.params = params
        self.features: list[MapFeature] = []
        self._next_id = 0

    # ---- state views -----------------------------------------------------------------------
    @property
    def x(self) -> np.ndarray:
        """The whole state (interface, then the map)."""
        self._flush()
        return self._x

    @property
    def P(self) -> np.ndarray:
        """The whole covariance."""
        self._flush()
        return self._P

    @P.setter
    def P(self, value) -> None:
        self._flush()
        self._P = np.array(value, float)

    @property
    def interface(self) -> np.ndarray:
        """The interface state (19,), current at every step (no flush)."""
        return self._x[: mm.DIM]

    @property
    def P_interface(self) -> np.ndarray:
        """The interface's covariance (19, 19), current at every step (no flush)."""
        return self._P[: mm.DIM, : mm.DIM]

    @property
    def n_features(self) -> int:
        return len(self.features)

    def feature(self, fid: int) -> MapFeature:
        for f in self.features:
            if f.fid == fid:
                return f
        raise KeyError(fid)

    def feature_points(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ids ``(k,)``, XYZ points in W ``(k, 3)`` and their covariances ``(k, 3, 3)``."""
        self._flush()
        ids, pts, covs = [], [], []
        for f in self.features:
            blk = slice(f.offset, f.offset + f.dim)
            y, Pyy = self._x[blk], self._P[blk, blk]
            if f.dim == idp.ID_DIM:
                pt, J = idp.to_xyz(y[None])
                pt, Pyy = pt[0], J[0] @ Pyy @ J[0].T
            else:
                pt = y
            ids.append(f.fid)
            pts.append(pt)
            covs.append(Pyy)
        return (np.array(ids, int), np.reshape(pts, (-1, 3)), np.reshape(covs, (-1, 3, 3)))

    # ---- time update -----------------------------------------------------------------------
    def predict(self, t: float) -> None:
        """Advance to time ``t`` (no-op if ``t`` is not later).  # Sugiyama eqs. 3-4

        Only the interface moves: ``P_aa = F P_aa F^T + Q`` now, the cross-covariance with the
        map (``F P_ab``) when the map is next read."""
        dt = t - self.t
        if dt <= 0.0:
            return
        x_new, F, G = mm.predict(self._x[: mm.DIM], dt)
        self._x[: mm.DIM] = x_new
        Paa = self._P[: mm.DIM, : mm.DIM]
        Paa[...] = F @ Paa @ F.T + mm.process_noise(G, self.params.noise)
        self._deferred.transition(F)
        self.t = float(t)

    # ---- inertial updates ------------------------------------------------------------------
    def update_inertial(self, q_meas: np.ndarray | None = None,
                        a_meas: np.ndarray | None = None,
                        w_meas: np.ndarray | None = None,
                        f_meas: np.ndarray | None = None, g_W: np.ndarray | None = None
                        ) -> None:
        """Fuse, in one update, an orientation ``q_WI`` (eq. 6), an acceleration in W (eq. 7)
        and/or an angular velocity in I (``h = ω``, the form of the arm's eq. 15), or instead
        of the acceleration in W the accelerometer's specific force ``f_meas`` in I with
        gravity ``g_W`` (:func:`mm.h_specific_force`). They read the interface only: the
        update is done on its 19x19 block, the map's share deferred (:mod:`.compressed`)."""
        given = (q_meas is not None, a_meas is not None, w_meas is not None,
                 f_meas is not None)
        if not any(given):
            return
        prm = self.params
        H, R = mm.inertial_model(given, prm.sigma_orientation, prm.sigma_accel, prm.sigma_gyro)
        xa = self._x[: mm.DIM]
        z = [align_sign(q_meas, xa[3:7])] if given[0] else []
        z += [a for a in (a_meas, w_meas, f_meas) if a is not None]
        if given[3]:  # the specific force's rows (the last three) are not linear
            h_f, H_f = mm.h_specific_force(xa, g_W)
            H = H.copy()
            H[-3:] = H_f
            nu = np.concatenate(z)
            nu[:-3] -= H[:-3] @ xa
            nu[-3:] -= h_f
        else:
            nu = np.concatenate(z) - H @ xa  # the other three models are linear: h = H x
        if given[0] and prm.orientation_tilt_yaw is not None:
            R = R.copy()
            R[0:4, 0:4] = self._orientation_noise()
        Paa = self._P[: mm.DIM, : mm.DIM]
        PHt = Paa @ H.T
        S = H @ PHt + R
        if not np.all(np.diagonal(S) > 0.0):
            return
        phi = self._deferred.phi if self._deferred.pending else np.eye(mm.DIM)
        HPhi = H @ phi
        try:  # one solve for S^-1 [H Φ, (P H^T)^T, ν]
            sol = np.linalg.solve(S, np.hstack([HPhi, PHt.T, nu[:, None]]))
        except np.linalg.LinAlgError:
            return
        SiHPhi, Kt, Sinu = sol[:, : mm.DIM], sol[:, mm.DIM:2 * mm.DIM], sol[:, -1]
        self._deferred.measured(HPhi, SiHPhi, Sinu, Kt)
        xa += Kt.T @ nu
        Paa -= Kt.T @ PHt.T
        up.symmetrize(Paa)  # rounding would otherwise grow while no feature is seen
        self._normalize_q()

    def _orientation_noise(self) -> np.ndarray:
        """Eq. 6's 4x4 noise for the anisotropic sensor error (:func:`mm.orientation_noise`),
        recomputed when the orientation has moved by more than ~1 deg."""
        q = self._x[3:7]
        cached = self._orient_noise
        if cached is None or abs(float(q @ cached[0])) < 0.99996:
            prm = self.params
            cached = (q.copy(), mm.orientation_noise(q, *prm.orientation_tilt_yaw,
                                                     prm.sigma_orientation))
            self._orient_noise = cached
        return cached[1]

    # ---- features --------------------------------------------------------------------------
    def _groups(self, feats: list[MapFeature]) -> list[tuple[np.ndarray, np.ndarray, int]]:
        """Per feature size: (indices into ``feats``, state offsets, size)."""
        out = []
        dims = np.array([f.dim for f in feats], int)
        offs = np.array([f.offset for f in feats], int)
        for d in (idp.ID_DIM, idp.XYZ_DIM):
            rows = np.flatnonzero(dims == d)
            if len(rows):
                out.append((rows, offs[rows], d))
        return out

    def predict_features(self, max_features: int | None = None) -> FeaturePrediction:
        """Predicted pixels and innovation covariances of the map features in view."""
        self._flush()
        p, q = self._x[0:3], self._x[3:7]
        feats = self.features
        k = len(feats)
        uv = np.full((k, 2), np.nan)
        H_pq = np.zeros((k, 2, 7))
        H_f: list[np.ndarray | None] = [None] * 2
        groups = self._groups(feats)
        for g, (rows, offs, d) in enumerate(groups):
            y = self._x[offs[:, None] + np.arange(d)]
            h, Hpq, Hy, z = idp.observe(y, p, q, self.intr, self.R_cv_I)
            h[z <= 1e-6] = np.nan
            uv[rows], H_pq[rows], H_f[g] = h, Hpq, Hy
        m = self.params.margin_px
        W, Hh = self.intr.width, self.intr.height
        vis = np.all(np.isfinite(uv), axis=1)
        vis[vis] &= ((uv[vis, 0] >= m) & (uv[vis, 0] <= W - 1 - m) & (uv[vis, 1] >= m)
                     & (uv[vis, 1] <= Hh - 1 - m))
        sel = np.flatnonzero(vis)
        if max_features is not None and len(sel) > max_features:
            sel = sel[:max_features]
        return self._prediction(feats, sel, uv, H_pq, groups, H_f)

    def _prediction(self, feats, sel, uv, H_pq, groups, H_f) -> FeaturePrediction:
        k = len(sel)
        n = len(self._x)
        if k == 0:
            return FeaturePrediction(np.zeros(0, int), np.zeros((0, 2)), np.zeros((0, 2, 2)),
                                     np.zeros((n, 0)), np.zeros((0, 0)))
        where = np.full(len(feats), -1)
        where[sel] = np.arange(k)
        sub = []
        for g, (rows, offs, _) in enumerate(groups):
            keep = where[rows] >= 0
            if keep.any():
                sub.append((where[rows[keep]], offs[keep], H_f[g][keep]))
        Hp = H_pq[sel].reshape(2 * k, 7)
        PHt = up.features_PHt(self._P, POSE_COLS, Hp, sub)
        S = up.features_S(PHt, POSE_COLS, Hp, sub, self.params.sigma_px)
        blocks = S.reshape(k, 2, k, 2)[np.arange(k), :, np.arange(k), :]
        fids = np.array([feats[i].fid for i in sel], int)
        return FeaturePrediction(fids, uv[sel], blocks, PHt, S)

    def update_features(self, pred: FeaturePrediction, matched: np.ndarray,
                        z: np.ndarray) -> bool:
        """Fuse the measured pixels ``z (m, 2)`` of the predicted features ``matched`` (indices
        into ``pred``); every other predicted feature counts as a failed attempt.
        # Sugiyama eqs. 8-9; one batch update, as Davison's MonoSLAM."""
        self._flush()  # (nothing pending between a prediction and its update)
        matched = np.asarray(matched, int)
        by_id = {f.fid: f for f in self.features}
        hit = np.zeros(len(pred.fids), bool)
        hit[matched] = True
        for fid, ok in zip(pred.fids, hit, strict=True):
            f = by_id[int(fid)]
            f.tries += 1
            f.hits += int(ok)
            f.misses_in_row = 0 if ok else f.misses_in_row + 1
        if len(matched) == 0:
            return False
        rows = (2 * matched[:, None] + np.arange(2)).ravel()
        nu = (np.asarray(z, float) - pred.uv[matched]).ravel()
        try:
            up.gain_update(self._x, self._P, pred.PHt[:, rows], pred.S_full[np.ix_(rows, rows)],
                           nu)
        except np.linalg.LinAlgError:
            return False
        self._normalize_q()
        up.symmetrize(self._P)
        return True

    # ---- map management --------------------------------------------------------------------
    def add_known(self, points_W: np.ndarray, sigma: float = 0.0) -> list[int]:
        """Prior known XYZ features (the screen corners), with isotropic std ``sigma`` (m)."""
        self._flush()
        pts = np.atleast_2d(np.asarray(points_W, float))
        k = len(pts)
        Pyy = np.kron(np.eye(k), sigma**2 * np.eye(3))
        return self._append(pts.ravel(), np.zeros((3 * k, len(self._x))), Pyy,
                            [idp.XYZ_DIM] * k, known=True)

    def add_features(self, uv: np.ndarray) -> list[int]:
        """New inverse-depth features at undistorted pixels ``uv (k, 2)``.
        # Civera et al. (2008) sec. III-C"""
        self._flush()
        uv = np.atleast_2d(np.asarray(uv, float))
        if len(uv) == 0:
            return []
        prm = self.params
        y, J_pq, J_z = idp.initialise(uv, self._x[0:3], self._x[3:7], self.intr, self.R_cv_I,
                                      prm.rho0)
        k = len(y)
        Jpq = J_pq.reshape(6 * k, 7)
        cross = Jpq @ self._P[POSE_COLS]  # (6k, n): new rows against the whole state
        Rz = np.diag([prm.sigma_px**2, prm.sigma_px**2, prm.sigma_rho**2])
        Pyy = cross[:, POSE_COLS] @ Jpq.T
        for i in range(k):
            blk = slice(6 * i, 6 * i + 6)
            Pyy[blk, blk] += J_z[i] @ Rz @ J_z[i].T
        return self._append(y.ravel(), cross, Pyy, [idp.ID_DIM] * k, known=False)

    def _append(self, y: np.ndarray, cross: np.ndarray, Pyy: np.ndarray, dims: list[int],
                known: bool) -> list[int]:
        off = len(self._x)
        self._x, self._P = sb.append(self._x, self._P, y, cross, Pyy)
        ids = []
        for d in dims:
            self.features.append(MapFeature(self._next_id, d, off, known=known))
            ids.append(self._next_id)
            self._next_id += 1
            off += d
        return ids

    def delete(self, fids) -> None:
        """Remove features (their rows and columns) from the state."""
        self._flush()
        drop = set(int(i) for i in fids)
        if not drop:
            return
        kept = [f for f in self.features if f.fid not in drop]
        cols = np.concatenate([np.arange(mm.DIM)]
                              + [np.arange(f.offset, f.offset + f.dim) for f in kept])
        self._x, self._P = sb.select(self._x, self._P, cols)
        self.features = kept
        self._reindex()

    def prune(self, min_tries: int = 10, min_hit_ratio: float = 0.5,
              max_misses_in_row: int = 5) -> list[int]:
        """Delete unreliable features (Davison: fewer than half of the attempts matched, or
        several failures in a row); known features stay. Returns the deleted ids."""
        bad = [f.fid for f in self.features if not f.known and (
            (f.tries >= min_tries and f.hits < min_hit_ratio * f.tries)
            or f.misses_in_row >= max_misses_in_row)]
        self.delete(bad)
        return bad

    def convert_linear(self, threshold: float = idp.LINEARITY_THRESHOLD) -> list[int]:
        """Convert inverse-depth features whose linearity index is below ``threshold`` to XYZ
        (Civera et al. 2008 sec. V). Returns the converted ids."""
        self._flush()
        inv = [f for f in self.features if f.dim == idp.ID_DIM]
        if not inv:
            return []
        offs = np.array([f.offset for f in inv])
        y = self._x[offs[:, None] + np.arange(6)]
        s_rho = np.sqrt(np.maximum(self._P[offs + 5, offs + 5], 0.0))
        L = idp.linearity_index(y, s_rho, self._x[0:3])
        conv = [f for f, li in zip(inv, L, strict=True) if li < threshold]
        if not conv:
            return []
        conv_ids = {f.fid for f in conv}
        src = np.array([f.offset for f in conv])[:, None] + np.arange(6)  # (c, 6) old cols
        pts, Js = idp.to_xyz(self._x[src])
        old, new, dst = [np.arange(mm.DIM)], [np.arange(mm.DIM)], []
        r = mm.DIM
        for f in self.features:
            if f.fid in conv_ids:
                dst.append(np.arange(r, r + 3))
                f.dim = idp.XYZ_DIM
            else:
                old.append(np.arange(f.offset, f.offset + f.dim))
                new.append(np.arange(r, r + f.dim))
            r += f.dim
        self._x, self._P = sb.convert(self._x, self._P, np.concatenate(old),
                                      np.concatenate(new), src, np.stack(dst), pts, Js)
        self._reindex()
        return sorted(conv_ids)

    def _reindex(self) -> None:
        off = mm.DIM
        for f in self.features:
            f.offset = off
            off += f.dim

    def _normalize_q(self) -> None:
        """Renormalise ``q`` after an update; the covariance through the normalisation's
        Jacobian ``J``: all of it after a map update, the interface block and the deferred
        cross-covariance (``Φ``'s quaternion rows) after an inertial one."""
        q = self._x[3:7]
        J = d_normalize(q)
        self._x[3:7] = q / math.sqrt(float(q @ q))
        d = self._deferred
        if not d.pending:
            up.transform_rows(self._P, slice(3, 7), J)
        else:
            up.transform_rows(self._P[: mm.DIM, : mm.DIM], slice(3, 7), J)
            d.phi[3:7] = J @ d.phi[3:7]

    def _flush(self) -> None:
        """Apply the deferred effect of the IMU steps to the map."""
        self._deferred.apply(self._x, self._P)
