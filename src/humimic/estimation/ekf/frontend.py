"""The image side of the EKF SLAM: undistortion, active-search patch matching, detection.

Sugiyama & Miura sec. III (after Davison's MonoSLAM): each map feature keeps the image patch
it was first seen with; in a new frame it is searched for only inside the ellipse where the
filter predicts it at 3 sigma (*active search*), by zero-mean normalised cross-correlation
(OpenCV's ``TM_CCOEFF_NORMED``; the paper used SAD). New features are Shi-Tomasi corners
(``cv2.goodFeaturesToTrack``) in image regions no map feature is predicted in, and never in
``mask``-ed pixels (the wearer's own arm, :mod:`.arm_mask`).

Every frame is undistorted first (the paper's SSE routine; here ``cv2.remap`` with maps from
:meth:`humimic.sensors.camera_model.Intrinsics.undistortion_maps`): matching, detection and
the filter then work in the pinhole image.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.estimation.ekf.arm_mask import ArmMaskParams, arm_mask
from humimic.sensors.camera_model import Intrinsics

#: Per-feature outcome of a frame, as the colours of the paper's Fig. 7.
MEASURED, FAILED, NOT_SELECTED = 0, 1, 2


@dataclass(frozen=True)
class FrontendParams:
    patch_px: int = 11
    """Side of the square patch (px, odd)."""
    search_sigma: float = 3.0
    """Search inside the ``search_sigma`` ellipse of the innovation covariance."""
    max_search_px: int = 48
    """Half-size cap of a search window (px): a very uncertain prediction is searched near
    its centre only (after a long coast the filter would otherwise search the whole image)."""
    min_zncc: float = 0.8
    """ZNCC a match must reach."""
    min_distance_px: int = 18
    """New features keep this far from predicted ones and from each other."""
    quality: float = 0.02
    """Shi-Tomasi quality level relative to the frame's best corner."""
    min_contrast: float = 6.0
    """Grey-level standard deviation a new feature's patch must have (a blank wall has none)."""


@dataclass
class Matches:
    """Outcome of active search over the predicted features of one frame."""

    index: np.ndarray
    """(m,) indices into the prediction of the features measured."""
    uv: np.ndarray
    """(m, 2) measured undistorted pixels."""
    score: np.ndarray
    """(m,) their ZNCC."""
    status: np.ndarray
    """(k,) per predicted feature: MEASURED, FAILED or NOT_SELECTED."""


def search_box(uv: np.ndarray, S: np.ndarray, n_sigma: float, cap: int) -> np.ndarray:
    """Half-sizes ``(k, 2)`` of the boxes bounding each ``n_sigma`` ellipse, capped (px)."""
    half = n_sigma * np.sqrt(np.maximum(S[:, [0, 1], [0, 1]], 0.0))
    return np.minimum(np.ceil(half), cap).astype(int)


def subpixel_peak(r: np.ndarray, i: int, j: int) -> tuple[float, float]:
    """Parabola-fitted offsets ``(dx, dy)`` of the maximum at ``r[i, j]`` (0 on the border)."""
    def vertex(a, b, c):
        den = a - 2.0 * b + c
        return 0.0 if den >= 0.0 else min(max(0.5 * (a - c) / den, -0.5), 0.5)
    h, w = r.shape
    dx = vertex(*r[i, j - 1:j + 2].tolist()) if 0 < j < w - 1 else 0.0
    dy = vertex(*r[i - 1:i + 2, j].tolist()) if 0 < i < h - 1 else 0.0
    return dx, dy


class Frontend:
    """Undistorts frames, keeps each feature's patch, matches and detects (pixels undistorted)."""

    def __init__(self, intr: Intrinsics, params: FrontendParams = FrontendParams()):
        self.intr = intr
        self.params = params
        map_x, map_y = intr.undistortion_maps()
        self._maps = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)
        self._half_maps = None
        self.patches: dict[int, np.ndarray] = {}

    # ---- images ----------------------------------------------------------------------------
    def undistort(self, image: np.ndarray) -> np.ndarray:
        """A distorted RGB (or grey) frame -> the undistorted grey image (uint8)."""
        grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
        return cv2.remap(grey, *self._maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def undistort_half(self, image: np.ndarray) -> np.ndarray:
        """A distorted frame -> its undistorted half-size version (what coarse masks use)."""
        if self._half_maps is None:
            intr = self.intr
            u, v = np.meshgrid(2.0 * np.arange(intr.width // 2) + 0.5,
                               2.0 * np.arange(intr.height // 2) + 0.5)
            ray = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones_like(u)],
                           -1)
            uv = intr.project(ray).astype(np.float32)
            self._half_maps = cv2.convertMaps(uv[..., 0], uv[..., 1], cv2.CV_16SC2)
        return cv2.remap(image, *self._half_maps, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)

    def arm_mask(self, image: np.ndarray, params: ArmMaskParams) -> np.ndarray:
        """The wearer's arm (:func:`.arm_mask.arm_mask`) in the undistorted image (bool, full
        size), computed on the undistorted half-size frame and upsampled."""
        half = arm_mask(self.undistort_half(image), params, scale=0.5).astype(np.uint8)
        m = cv2.resize(half, (self.intr.width, self.intr.height),
                       interpolation=cv2.INTER_NEAREST)
        return m.astype(bool)

    # ---- patches ---------------------------------------------------------------------------
    def cut(self, grey: np.ndarray, uv: np.ndarray) -> list[np.ndarray | None]:
        """Patches centred on the sub-pixel positions ``uv (k, 2)`` (bilinear,
        ``cv2.getRectSubPix``); None where one does not fit in the image."""
        r = self.params.patch_px // 2
        s = self.params.patch_px
        h, w = grey.shape
        out: list[np.ndarray | None] = []
        for u, v in np.asarray(uv, float).tolist():
            ok = r <= u <= w - 1 - r and r <= v <= h - 1 - r
            out.append(cv2.getRectSubPix(grey, (s, s), (u, v)) if ok else None)
        return out

    def add(self, fids, grey: np.ndarray, uv: np.ndarray) -> list[int]:
        """Store the patches of new features; returns the ids whose patch did not fit."""
        bad = []
        for fid, patch in zip(fids, self.cut(grey, uv), strict=True):
            if patch is None:
                bad.append(int(fid))
            else:
                self.patches[int(fid)] = patch
        return bad

    def drop(self, fids) -> None:
        for fid in fids:
            self.patches.pop(int(fid), None)

    # ---- active search ---------------------------------------------------------------------
    def match(self, grey: np.ndarray, fids: np.ndarray, uv: np.ndarray, S: np.ndarray,
              mask: np.ndarray | None = None, select: np.ndarray | None = None) -> Matches:
        """Search each predicted feature (ids ``fids``, pixels ``uv``, innovation covariances
        ``S (k, 2, 2)``) inside its ``search_sigma`` ellipse; ``select`` (bool, k) limits which are
        searched (the rest are NOT_SELECTED), ``mask`` (bool image) marks pixels not to match
        in. A feature is measured where its best ZNCC inside the ellipse reaches
        ``min_zncc``."""
        prm = self.params
        k = len(fids)
        status = np.full(k, NOT_SELECTED)
        idx, out_uv, score = [], [], []
        if k == 0:
            return Matches(np.zeros(0, int), np.zeros((0, 2)), np.zeros(0), status)
        r = prm.patch_px // 2
        h, w = grey.shape
        half = search_box(uv, S, prm.search_sigma, prm.max_search_px).tolist()
        S_inv = np.linalg.inv(S).reshape(k, 4).tolist()
        centre = uv.tolist()
        lim = prm.search_sigma**2
        for i in range(k):
            if select is not None and not select[i]:
                continue
            status[i] = FAILED
            patch = self.patches.get(int(fids[i]))
            if patch is None:
                continue
            pu, pv = centre[i]
            cu, cv_ = int(round(pu)), int(round(pv))
            x0, x1 = max(cu - half[i][0], r), min(cu + half[i][0], w - 1 - r)
            y0, y1 = max(cv_ - half[i][1], r), min(cv_ + half[i][1], h - 1 - r)
            if x1 < x0 or y1 < y0:
                continue
            res = cv2.matchTemplate(grey[y0 - r:y1 + r + 1, x0 - r:x1 + r + 1], patch,
                                    cv2.TM_CCOEFF_NORMED)
            a, b, _, d = S_inv[i]
            _, best, _, (ix, iy) = cv2.minMaxLoc(res)
            du, dv = x0 + ix - pu, y0 + iy - pv
            outside = a * du * du + 2 * b * du * dv + d * dv * dv > lim
            if outside or (mask is not None and mask[y0 + iy, x0 + ix]):
                # the box's best lies outside the ellipse or on the arm: search the allowed part
                gu = np.arange(x0, x1 + 1) - pu
                gv = (np.arange(y0, y1 + 1) - pv)[:, None]
                res[a * gu * gu + 2 * b * gu * gv + d * gv * gv > lim] = -1.0
                if mask is not None:
                    res[mask[y0:y1 + 1, x0:x1 + 1]] = -1.0
                _, best, _, (ix, iy) = cv2.minMaxLoc(res)
            if not best >= prm.min_zncc:  # also rejects NaN (a flat window)
                continue
            dx, dy = subpixel_peak(res, iy, ix)
            idx.append(i)
            out_uv.append((x0 + ix + dx, y0 + iy + dy))
            score.append(best)
            status[i] = MEASURED
        return Matches(np.array(idx, int), np.reshape(out_uv, (-1, 2)), np.array(score),
                       status)

    # ---- detection -------------------------------------------------------------------------
    def detect(self, grey: np.ndarray, n: int, avoid_uv: np.ndarray,
               mask: np.ndarray | None = None) -> np.ndarray:
        """Up to ``n`` new corners ``(m, 2)`` away from ``avoid_uv`` (predicted features), the
        border and ``mask``-ed pixels, with enough contrast to be matched again."""
        if n <= 0:
            return np.zeros((0, 2))
        prm = self.params
        h, w = grey.shape
        r = prm.patch_px // 2 + 2
        allowed = np.zeros((h, w), np.uint8)
        allowed[r:h - r, r:w - r] = 255
        if mask is not None:
            allowed[mask] = 0
        for u, v in np.rint(avoid_uv[np.all(np.isfinite(avoid_uv), axis=1)]).astype(int):
            cv2.circle(allowed, (int(u), int(v)), prm.min_distance_px, 0, -1)
        pts = cv2.goodFeaturesToTrack(grey, 2 * n, prm.quality, prm.min_distance_px,
                                      mask=allowed, blockSize=5)
        if pts is None:
            return np.zeros((0, 2))
        pts = pts.reshape(-1, 2).astype(float)
        keep = [i for i, p in enumerate(self.cut(grey, pts))
                if p is not None and float(p.std()) >= prm.min_contrast]
        return pts[keep[:n]]
