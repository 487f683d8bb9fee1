"""Which stereo pair GEST measures in: the narrow (foveal) pair while the hand is in its view.

Each of the robot's eyes carries a wide (100 deg) and a coaxial foveal (24 deg) camera. A blob
centroid's disparity error is what limits GEST's depth (:mod:`.stereo`); in the foveal pair the
same error is 5.6x fewer millimetres (``Z^2 / (f b)`` per pixel, ``f`` 5.6x longer). The foveal
view is narrow: the tracker measures in it only while its last estimate's hand image -- a
circle of the ellipsoid's longest semi-axis about the projected centre -- lies inside both
foveal images with a margin; otherwise (and to (re-)initialise) in the wide pair.
"""

from __future__ import annotations

import numpy as np

from humimic.sensors.camera_model import CameraModel


def hand_inside(camera: CameraModel, p_base: np.ndarray, radius_m: float, margin_px: float
                ) -> bool:
    """Whether a sphere of ``radius_m`` at ``p_base`` (robot base frame) images wholly inside
    ``camera``'s image, ``margin_px`` from every border (its image radius taken as
    ``fx * radius / depth`` at the centre's depth)."""
    T_cam_base = camera.T_cam_base
    depth = float(T_cam_base[2, :3] @ p_base + T_cam_base[2, 3])
    if depth <= radius_m:
        return False
    uv = camera.project_base(np.asarray(p_base, float)[None])[0]
    K = camera.intrinsics
    r = K.fx * radius_m / depth + margin_px
    return bool(np.isfinite(uv).all() and r <= uv[0] <= K.width - r
                and r <= uv[1] <= K.height - r)


def choose_pair(wide: tuple, foveal: tuple | None, estimate: np.ndarray | None,
                margin_px: float) -> tuple:
    """The ``(left, right)`` frames to measure in: ``foveal`` when there is one and the
    estimate's hand (state ``(9,)``: centre, angles, semi-axes) is inside both of its images,
    else ``wide``."""
    if foveal is None or estimate is None or any(f is None for f in foveal):
        return wide
    radius = float(np.max(estimate[6:9]))
    if all(hand_inside(f.camera, estimate[:3], radius, margin_px) for f in foveal):
        return foveal
    return wide
