"""A stereo match refused while its blob is being hidden: the visible target mass in each eye.

Our extension of Ude & Atkeson's eq. 10. Stereo matches the colour-masked blob, i.e. its
outline. While a body part passes behind a nearer one (a hand going behind the torso as the
person turns), part of that outline is the *occluder's* edge, at the occluder's depth, and the
nearer the occluder the more it hides in one eye than in the other (a half-occluded strip as
wide as the two depths' disparity difference: Belhumeur & Mumford, "A Bayesian treatment of the
stereo correspondence problem using half-occluded regions", CVPR 1992; Geiger, Ladendorf &
Yuille, "Occlusions and binocular stereo", IJCV 14, 1995). The match then slides towards the
occluder's disparity while the blob still looks fine: in ``ude_cmu_turn`` (seed 1, the right
hand, ~40 px, 1.6 m away) the three frames before the hand was lost had disparity errors of
0.29, 0.47, 0.68 px (the match's noise: ~0.07 px) -- 110, 174, 244 mm nearer than the hand --
with ZNCC scores of 0.985-0.987, blob centres within 1 px of the truth in both eyes, the
ZNCC and the mass-centroid alignments agreeing (0.0-0.1 px) and the two eyes' target areas
and widths along the epipolar line differing no more than in frames matched right. What
set them apart was the visible mass itself: in each eye the target pixels of the matched window
had fallen to 0.79, 0.75, 0.56 of their largest over the last 0.1 s (ground truth: the hand was
0.90, 0.83, 0.65 unoccluded in the worse eye), while over every frame of the waving hands
(``ude_wave_tracking`` seed 1, ``mimic_tracked_wave`` seed 7 at 1.8 m) and the turn's frames
before the occlusion it never fell below 0.85.

So a measurement is refused (reason ``shrinking_blob``) when, in either eye,
:func:`visible_mass_ratio` is below ``perception.stereo.min_visible_ratio``.
"""

from __future__ import annotations

from collections import deque

import numpy as np


def target_fraction(luts, targets: list[int], samples: np.ndarray) -> np.ndarray:
    """Mean of ``p / (p + 1)`` over each (colour-masked) window of samples ``(n, h, w, C)``:
    how much of it is target-coloured (one table lookup per distinct colour model,
    ``luts[targets[r]]`` for window ``r``)."""
    out = np.zeros(len(targets))
    px = samples if samples.dtype == np.uint8 else \
        np.clip(samples, 0, 255).astype(np.uint8)
    for lut in {id(luts[i]): luts[i] for i in targets}.values():
        rows = [r for r, i in enumerate(targets) if luts[i] is lut]
        p = lut.lookup(px[rows]).astype(np.float64)
        out[rows] = (p / (p + 1.0)).mean(axis=(1, 2))
    return out


def window_mass_px(fraction: np.ndarray, side: int, spacing: np.ndarray) -> np.ndarray:
    """Target pixels (px^2) of square windows of ``side`` x ``side`` samples spaced ``spacing``
    px apart whose mean target fraction is ``fraction``: ``fraction side^2 spacing^2``."""
    return np.asarray(fraction, float) * side**2 * np.square(np.asarray(spacing, float))


def visible_mass_ratio(mass_px: np.ndarray, recent_px: np.ndarray) -> float:
    """``min_e mass_e / max_k recent_{k,e}`` over the eyes ``e``: the share of its recent
    visible mass a blob still shows in the eye where it shrank most (``mass_px (2,)`` now,
    ``recent_px (K, 2)`` the earlier frames of the window). 1 without history; an eye whose
    recent maximum is 0 counts as 1."""
    recent = np.asarray(recent_px, float).reshape(-1, 2)
    if len(recent) == 0:
        return 1.0
    ref = recent.max(axis=0)
    now = np.asarray(mass_px, float)
    ratio = np.where(ref > 0.0, now / np.where(ref > 0.0, ref, 1.0), 1.0)
    return float(ratio.min())


class VisibleMass:
    """Per target, the matched windows' target masses (left, right) over the last ``window_s``
    seconds, and the ratio of a new frame's to them (:func:`visible_mass_ratio`)."""

    def __init__(self, window_s: float) -> None:
        self.window_s = float(window_s)
        self._hist: dict[str, deque] = {}

    def update(self, name: str, t: float, mass_px: np.ndarray) -> float:
        """Add frame ``t``'s masses and return their ratio to the earlier ones in the window."""
        h = self._hist.setdefault(name, deque())
        while h and h[0][0] < t - self.window_s - 1e-9:
            h.popleft()
        ratio = visible_mass_ratio(mass_px, [m for _, m in h])
        h.append((t, np.asarray(mass_px, float).copy()))
        return ratio
