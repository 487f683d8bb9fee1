"""Our extension (issue 14): a hand's skin surround, a cue that sees the hand's image size.

Schmidt's skin cue (eq. 8) is the fraction of skin inside the model hand's image ellipse: a
model hand projected too small (too far from the camera) still lies inside the skin blob and
scores as well as the right one. A monocular arm's kinematic mirrors (:mod:`~humimic.
perception.trackers.kpf.flips`) put the hand at the same image point but at another range,
so at another image size: in Table 1's angular pointing hold (the wide eye, 320 x 240, 2 m)
the true hand's ellipse has semi-axes ~6.5 x 3.5 px at 1.6 m, its mirrors' ~5 x 2.3 px at
1.9-2.1 m; the skin fraction of the disc 1.4 x the model ellipse is 0.53 at the truth and
0.71-0.88 at the mirrors. The surround term scores the fraction ``s`` of skin on the sides of a
ring (:data:`RING_POINTS` points) at ``scale`` times the model ellipse's semi-axes
(:func:`ring_skin`) as a cost, ``-s^2 / (2 sigma^2)`` (:func:`ring_log_term`, eq. 9's form),
added to the hand's log-likelihood term: a hand too small for its blob is penalised.
"""

from __future__ import annotations

import numpy as np

from humimic.bodymodel.conics import rotated_ellipse_points
from humimic.perception.trackers.kpf.cues import CueMaps, sample

#: Points on the surround ring: two arcs of +-45 deg about the minor axis (the hand's sides,
#: evenly spaced in the ellipse's parameter angle), not along the major axis, where the hand
#: continues into the wrist and the fingers.
RING_POINTS = 16
_T = np.concatenate([np.linspace(-0.25 * np.pi, 0.25 * np.pi, RING_POINTS // 2) + a
                     for a in (0.5 * np.pi, 1.5 * np.pi)])
_UNIT = np.stack([np.cos(_T), np.sin(_T)], axis=-1)


def ring_points(centre: np.ndarray, axes: np.ndarray, angle: np.ndarray, scale: float
                ) -> np.ndarray:
    """``(N, E, RING_POINTS, 2)`` points (pixels) of the ellipses with centres ``(N, E, 2)``,
    semi-axes ``(N, E, 2)`` (major, minor) times ``scale`` and major-axis angles ``(N, E)``
    (rad): ``centre + R(angle) (scale a cos t, scale b sin t)``."""
    return rotated_ellipse_points(centre, scale * axes, np.cos(angle), np.sin(angle), _UNIT)


def ring_skin(maps: CueMaps, centre: np.ndarray, axes: np.ndarray, angle: np.ndarray,
              scale: float) -> np.ndarray:
    """``(N, E)`` the fraction of skin pixels on the :func:`ring_points` of the ellipses
    (off the maps: not skin)."""
    pts = ring_points(centre, axes, angle, scale)
    return sample(maps.skin, pts, maps.origin).mean(axis=-1)


def ring_log_term(skin: np.ndarray, sigma: float) -> np.ndarray:
    """Eq. 9's Gaussian of the surround's cost, the ring's skin fraction ``skin``:
    ``-skin^2 / (2 sigma^2)`` (log)."""
    return -np.square(skin) / (2.0 * sigma * sigma)


def ring_pad(axes: np.ndarray, scale: float) -> float:
    """How far (px) the rings reach beyond the ellipses' major radius (the cue maps must
    cover them)."""
    finite = axes[np.isfinite(axes)]
    return float(max(scale - 1.0, 0.0) * finite.max()) + 1.0 if finite.size else 1.0
