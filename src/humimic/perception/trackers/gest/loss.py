"""GEST's loss test (Menezes sec. 6.1: automatic recovery after the hand is lost): does a
hand-sized ellipse fit the left image's edges or skin rim at the published centre?

The skin rim fits when the skin posterior just inside it is at least ``odds`` times that just
outside (:func:`rim_fits`, the 2-D hand tracker's relative test,
:func:`~humimic.perception.cues.skin.rim_separates`), not when ``D_k = 1 - (inside - outside)``
is small: how high a hand's skin posterior reads depends on its skin tone and shading.

The estimate's own ellipse is tried first (:class:`.tracker.GestTracker`); when it does not
fit, :func:`any_pose_fits` tries the ellipsoid seen along each of its axes, turned in the
image: the test asks whether the hand is where GEST says it is, not whether its orientation
estimate is right (that is scored apart, ``orientation_rmse_deg``). A hand that left the view
or is cut by the border has no stereo candidate and is declared lost by the tracker's
support test; a wrong skin blob of another size (a face) fits no hand-sized ellipse.
"""

from __future__ import annotations

import math

import numpy as np

from humimic.perception.cues.skin import rim_separates, rim_skin_sides
from humimic.perception.trackers.gest.likelihood import (
    RIM_OFFSET_PX,
    HandProjection,
    HandView,
    ellipse_family,
    shape_distance,
)

#: The image-plane turns (rad) of the hand-sized ellipses the loss test tries when the
#: estimate's own does not fit (an ellipse is symmetric under a half turn; 22.5 deg apart).
LOSS_TEST_ANGLES = np.linspace(0.0, math.pi, 8, endpoint=False)


def lost_threshold_px(state: np.ndarray, camera, floor_px: float, rel: float) -> float:
    """The largest mean contour distance (px) of a tracked hand: ``rel`` times its image
    radius (``fx`` times the longest semi-axis over the centre's depth; the ellipsoid's misfit
    to the hand's outline grows with its image), at least ``floor_px``."""
    T = camera.T_cam_base
    depth = float(T[2, :3] @ state[:3] + T[2, 3])
    if depth <= 0.0:
        return floor_px
    return max(floor_px, rel * camera.intrinsics.fx * float(np.max(state[6:9])) / depth)


def rim_fits(proj: HandProjection, view: HandView, odds: float) -> np.ndarray:
    """Per contour of ``proj``, whether its rim separates skin from background in ``view``:
    the skin posterior ``RIM_OFFSET_PX`` inside at least ``odds`` times that outside
    (:func:`~humimic.perception.cues.skin.rim_separates`)."""
    return rim_separates(*rim_skin_sides(view.skin, proj.contour, proj.normal, RIM_OFFSET_PX),
                         odds)


def any_pose_fits(state: np.ndarray, proj, view, n_points: int, limit_px: float,
                  rim_odds: float) -> bool:
    """Whether an ellipse of the hand's size at the estimate's image centre fits the edges
    (mean distance at most ``limit_px``) or the skin rim (:func:`rim_fits` with ``rim_odds``)
    in some pose: the ellipsoid seen along each of its axes (semi-axes pairs over the centre's
    depth), turned in the image by :data:`LOSS_TEST_ANGLES`. The loss test asks whether the
    hand is at the published centre; the orientation estimate is not part of it (a dark
    hand with few edges, its orientation 90 deg off, was declared lost on a third of its
    frames while its centre was within 8 mm)."""
    T = view.T_cam_base
    depth = float(T[2, :3] @ state[:3] + T[2, 3])
    if depth <= 0.0 or not np.isfinite(proj.patch_state[0, :2]).all():
        return False
    a = view.intrinsics.fx * np.asarray(state[6:9], float) / depth
    pairs = np.array([[a[0], a[1]], [a[0], a[2]], [a[1], a[2]]])
    family = ellipse_family(proj.patch_state[0, :2], pairs, LOSS_TEST_ANGLES, n_points)
    return bool(shape_distance(family, view).min() <= limit_px
                or rim_fits(family, view, rim_odds).any())
