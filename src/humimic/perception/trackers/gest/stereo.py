"""GEST's importance function (Menezes sec. 6.1.2): skin blobs matched between the robot's two
eyes, triangulated, with the covariance of eq. 17.

Every left/right pair of skin blobs is triangulated (DLT on undistorted normalised points,
:mod:`humimic.perception.blobs.triangulation`) and kept if it reprojects into both images
within ``max_epipolar_px`` (the match heuristic), lies in front of both cameras, and its
physical size (``sqrt(area) * depth / f``) is a hand's, which rejects the face blob (the
paper filters it with the face detector). The covariance is eq. 17,
``Sigma = G_L sigma_L G_L^T + G_R sigma_R G_R^T`` with ``G`` the triangulation's Jacobians and
``sigma`` the blobs' inertia matrices (here the boxes' ``diag(w^2, h^2) / 12``, scaled).
"""

from __future__ import annotations

import numpy as np

from humimic.perception.blobs.triangulation import dlt_jacobian, triangulate_dlt
from humimic.perception.cues.importance import Blobs
from humimic.sensors.camera_model import CameraModel


def blob_inertia(blobs: Blobs, scale: float = 1.0) -> np.ndarray:
    """``(K, 2, 2)`` pixel covariances of the blobs: a uniform box's ``diag(w^2, h^2) / 12``
    times ``scale^2``."""
    w, h = blobs.boxes[:, 2], blobs.boxes[:, 3]
    C = np.zeros((len(w), 2, 2))
    C[:, 0, 0], C[:, 1, 1] = w * w / 12.0, h * h / 12.0
    return C * scale * scale


def stereo_candidates(left: Blobs, right: Blobs, cam_l: CameraModel, cam_r: CameraModel,
                      max_epipolar_px: float, size_range: tuple[float, float],
                      sigma_scale: float = 1.0, centroid_px: float = 1.0
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Triangulated hand candidates: positions ``(M, 3)`` and covariances ``(M, 3, 3)`` in the
    robot base frame (m) from every matching left/right blob pair (module docstring), and the
    covariances ``(M, 3, 3)`` of the triangulated *centroids* for an isotropic centroid error
    of ``centroid_px`` in each image (the same Jacobians; eq. 17's inertia is the blob's
    spread, much wider than its centroid's error), and the matched centroids ``(M, 2, 2)``
    (left, right; px)."""
    kl, kr = len(left.areas), len(right.areas)
    if kl == 0 or kr == 0:
        return _NONE
    il, ir = np.divmod(np.arange(kl * kr), kr)          # every pair, left-major
    P1 = cam_l.T_cam_base[:3]
    P2 = cam_r.T_cam_base[:3]
    x1 = cam_l.intrinsics.undistort_normalized(left.centers)[il]       # per point: per blob
    x2 = cam_r.intrinsics.undistort_normalized(right.centers)[ir]
    X_h, svd = triangulate_dlt(P1, P2, x1, x2)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = X_h[:, :3] / X_h[:, 3:]
        res_l = np.linalg.norm(cam_l.project_base(p) - left.centers[il], axis=1)
        res_r = np.linalg.norm(cam_r.project_base(p) - right.centers[ir], axis=1)
    z_l = p @ P1[:, :3].T[:, 2] + P1[2, 3]
    z_r = p @ P2[:, :3].T[:, 2] + P2[2, 3]
    size = np.sqrt(left.areas[il]) * z_l / cam_l.intrinsics.fx
    keep = ((z_l > 0) & (z_r > 0) & (np.maximum(res_l, res_r) <= max_epipolar_px)
            & (size >= size_range[0]) & (size <= size_range[1]))
    if not keep.any():
        return _NONE
    if not keep.all():
        X_h, svd = X_h[keep], tuple(a[keep] for a in svd)
    G = dlt_jacobian(P1, P2, X_h, svd)                                 # (M, 3, 4) normalised
    # pixel -> normalised scaling N = diag(1/fx, 1/fy): N S N = S * n n^T
    n_l = np.array([1.0 / cam_l.intrinsics.fx, 1.0 / cam_l.intrinsics.fy])
    n_r = np.array([1.0 / cam_r.intrinsics.fx, 1.0 / cam_r.intrinsics.fy])
    s_l = blob_inertia(left, sigma_scale)[il[keep]] * np.outer(n_l, n_l)
    s_r = blob_inertia(right, sigma_scale)[ir[keep]] * np.outer(n_r, n_r)
    G_l, G_r = G[:, :, :2], G[:, :, 2:]
    G_lT, G_rT = np.swapaxes(G_l, 1, 2), np.swapaxes(G_r, 1, 2)
    cov = G_l @ s_l @ G_lT + G_r @ s_r @ G_rT                          # Menezes eq. 17
    cen = ((G_l * (centroid_px * n_l) ** 2) @ G_lT
           + (G_r * (centroid_px * n_r) ** 2) @ G_rT)
    uv = np.stack([left.centers[il[keep]], right.centers[ir[keep]]], 1)
    return _one_per_left_blob(p[keep], cov, cen, uv, il[keep],
                              np.maximum(res_l, res_r)[keep])


def interior_blobs(blobs: Blobs, width: int, height: int, margin_px: float = 1.0) -> Blobs:
    """The blobs whose box keeps ``margin_px`` from every image border: a blob cut by the
    border (the hand leaving the view) has its centroid displaced towards the image, and a
    triangulation of it is not the hand's."""
    x, y, w, h = blobs.boxes.T
    keep = ((x >= margin_px) & (y >= margin_px) & (x + w <= width - margin_px)
            & (y + h <= height - margin_px))
    if keep.all():                          # the usual case (and no blobs): as they are
        return blobs
    return Blobs(blobs.centers[keep], blobs.boxes[keep], blobs.areas[keep])


def triangulate_pixels(cam_l: CameraModel, cam_r: CameraModel, uv_l: np.ndarray,
                       uv_r: np.ndarray) -> np.ndarray:
    """Base-frame points ``(N, 3)`` of left/right pixel pairs ``(N, 2)`` (DLT)."""
    P1 = cam_l.T_cam_base[:3]
    P2 = cam_r.T_cam_base[:3]
    X_h, _ = triangulate_dlt(P1, P2, cam_l.intrinsics.undistort_normalized(uv_l),
                             cam_r.intrinsics.undistort_normalized(uv_r))
    return X_h[:, :3] / X_h[:, 3:]


_NONE = (np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3, 3)), np.zeros((0, 2, 2)))


def _one_per_left_blob(p, cov, cen, uv, il, residual) -> tuple[np.ndarray, ...]:
    """Of the matches of one left blob keep the one with the smallest reprojection residual."""
    if len(il) == 1:
        return p, cov, cen, uv
    order = np.lexsort((residual, il))
    first = np.ones(len(order), bool)
    first[1:] = il[order][1:] != il[order][:-1]
    pick = order[first]
    return p[pick], cov[pick], cen[pick], uv[pick]
