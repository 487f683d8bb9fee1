"""One frame's cue maps computed on first use and only where the particles look.

Schmidt's cues are read at feature points on the projected limbs only, and the particles of a
frame project into a small part of the image (6-11 % of the 320 x 240 frame in the Table-1
runs). :class:`FrameCues` holds the frame and computes the maps
(:func:`~humimic.perception.trackers.kpf.cues.cue_maps`) over the bounding box of the sample
points a likelihood evaluation needs (:func:`sample_box`), widened by :data:`MARGIN_PX` so the
filters' and the pyramid's supports lie inside it: the maps there equal the whole image's, so
the likelihood is unchanged. A later evaluation reaching outside recomputes over the union.
"""

from __future__ import annotations

import math

import numpy as np

from humimic.bodymodel.projection import BodyView
from humimic.maths.jit import njit
from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.trackers.kpf.cues import CueMaps, cue_maps

#: Border (px) around the sample points: the level-2 ridge value at a point depends on image
#: pixels up to 12 px away (blur 2, pyrDown 2 + 4, second derivative 4), plus rounding.
MARGIN_PX = 16
#: Regions start at multiples of this (pyramid level 2 aligned with the whole image's).
ALIGN_PX = 8


def sample_box(view: BodyView, ellipses=None) -> tuple[np.ndarray, np.ndarray]:
    """Image bounding box ``(lo, hi)`` (pixels) of every limb and ellipse sample point of
    ``view``: limbs lie between their contour generators' and axis' ends (edges, bands and
    axis points interpolate them), the skin points within the image ellipses' major radius
    of their centres (``ellipses`` as :meth:`BodyView.ellipses_px`, computed if None)."""
    centre, axes, _ = view.ellipses_px() if ellipses is None else ellipses
    lo, hi = _box_kernel(view.sides_uv.reshape(-1, 2), view.axis_uv.reshape(-1, 2),
                         centre.reshape(-1, 2), axes.reshape(-1, 2))
    return lo, hi


@njit
def _extend(x, first, a, b):
    """The range ``[a, b]`` extended to ``x`` if finite (``first``: none yet)."""
    if not np.isfinite(x):
        return first, a, b
    if first:
        return False, x, x
    return False, min(a, x), max(b, x)


@njit
def _box_kernel(sides, axis, centre, axes):
    """:func:`sample_box`'s loop: the extremes of the finite coordinates of the points and of
    the ellipse centres +- their larger semi-axis (0 where there are none)."""
    lo, hi = np.zeros(2), np.zeros(2)
    for k in range(2):
        first, a, b = True, 0.0, 0.0
        for i in range(sides.shape[0]):
            first, a, b = _extend(sides[i, k], first, a, b)
        for i in range(axis.shape[0]):
            first, a, b = _extend(axis[i, k], first, a, b)
        for i in range(centre.shape[0]):
            r0, r1 = axes[i, 0], axes[i, 1]
            r = np.nan if np.isnan(r0) or np.isnan(r1) else max(r0, r1)   # np.maximum
            first, a, b = _extend(centre[i, k] - r, first, a, b)
            first, a, b = _extend(centre[i, k] + r, first, a, b)
        lo[k], hi[k] = a, b
    return lo, hi


class FrameCues:
    """A frame's cue maps over the part of the image the particles need (computed lazily)."""

    def __init__(self, image: np.ndarray, skin_lut: ColorLUT, **kw):
        self.image, self.skin_lut, self.kw = image, skin_lut, kw
        self.maps: CueMaps | None = None
        self.region: tuple[int, int, int, int] | None = None
        """``(u0, v0, u1, v1)`` of :attr:`maps`."""

    def covering(self, lo: np.ndarray, hi: np.ndarray) -> CueMaps:
        """Maps valid for every sample point in the box ``lo``-``hi`` (pixels)."""
        h, w = self.image.shape[:2]
        a = ALIGN_PX
        (lu, lv), (hu, hv) = lo.tolist(), hi.tolist()   # scalars: plain Python is faster
        u0 = min(max(math.floor((lu - MARGIN_PX) / a) * a, 0), max(w - a, 0) // a * a)
        v0 = min(max(math.floor((lv - MARGIN_PX) / a) * a, 0), max(h - a, 0) // a * a)
        # + 4: a point's nearest level-2 pixel may lie up to half a pixel (2 px) beyond it
        # the far edges rounded up to multiples of ALIGN_PX too: a little slack, so fewer
        # later evaluations reach outside and recompute the maps
        u1 = min(max(-(-math.ceil(hu + MARGIN_PX + 4) // a) * a, u0 + a), w)
        v1 = min(max(-(-math.ceil(hv + MARGIN_PX + 4) // a) * a, v0 + a), h)
        if self.region is not None:
            r = self.region
            if r[0] <= u0 and r[1] <= v0 and u1 <= r[2] and v1 <= r[3]:
                return self.maps
            u0, v0, u1, v1 = min(u0, r[0]), min(v0, r[1]), max(u1, r[2]), max(v1, r[3])
        self.region = (u0, v0, u1, v1)
        self.maps = cue_maps(self.image, self.skin_lut, region=self.region, **self.kw)
        return self.maps

    def whole(self) -> CueMaps:
        """Maps of the whole image."""
        h, w = self.image.shape[:2]
        return self.covering(np.array([0.0, 0.0]), np.array([w, h], float))
