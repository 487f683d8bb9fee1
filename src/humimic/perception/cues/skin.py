"""The skin inside/outside cue of a contour (added here to Menezes' shape and colour cues).

Where a hand's grey-level edges are weak (a dark hand over a dark shirt) or drowned in clutter
(a speckled cupboard behind a waving hand), the skin posterior still says which side of a
contour the hand is on: ``D = 1 - (mean skin just inside - mean skin just outside)`` in
[0, 2], 0 for a contour on the rim of a skin region, 1 where skin is on neither or both sides,
2 for the contour of a hole in skin. Used by GEST (on the projected ellipse) and the 2-D hand
tracker (on its template) with :func:`~humimic.perception.cues.edges.shape_log_likelihood`.
"""

from __future__ import annotations

import numpy as np

from humimic.perception.cues.edges import sample


def rim_skin_distance(skin: np.ndarray, contour: np.ndarray, outward: np.ndarray,
                      offset_px: float = 2.0) -> np.ndarray:
    """``D = 1 - (inside - outside)`` per contour ``(..., n, 2)`` (px) with outward unit
    normals ``outward`` (same shape): the skin posterior map ``skin`` sampled bilinearly
    ``offset_px`` either side of every point (off the map counts 0), averaged over the
    ``n`` points; one gather for both sides."""
    step = offset_px * np.asarray(outward)
    inside, outside = sample(skin, np.stack([contour - step, contour + step]), 0.0).mean(
        axis=-1)
    return 1.0 - (inside - outside)
