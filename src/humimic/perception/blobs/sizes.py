"""Head or hand by metric size: a graded likelihood ratio (ours; used by
:mod:`humimic.perception.blobs.identity`'s size rule).

A stereo-consistent blob pair gives the blob's metric "sigma radius" ``r = det(Sigma)^(1/4) z /
f`` (m). The true sigma radius of a part depends on the side it is seen from: a uniform
elliptic silhouette with semi-axes ``a, b`` has ``sqrt(a b) / 2``, so the avatar's head
(``models/avatar.xml``, half-axes 95 x 78 x 115 mm) measures 47.4 mm from the front to 52.3 mm
from the side, and a hand (45 x 22 x 80 mm) 15.7 mm end-on to 30.0 mm palm-on. Each class is a
uniform interval ``[lo, hi]`` of true radii; the measured one adds Gaussian noise of standard
deviation

    s(z) = sqrt(s0^2 + (s_px z / f)^2)

(:func:`radius_sd_m`): ``s_px`` of the blob's sigma radius in pixels (its boundary known to
about a pixel) grows in metres with the depth, ``s0`` for the rest (shading, segmentation).
The likelihood of a reading ``r`` (:func:`size_log_likelihood`) is then the uniform density
convolved with the noise,

    p(r | lo, hi) = [Phi((r - lo) / s) - Phi((r - hi) / s)] / (hi - lo),

and for a blob cut by the image border, whose reading is only a lower bound of its size, the
probability of a size at least ``r``,

    P(R + e >= r) = s / (hi - lo) [G((hi - r) / s) - G((lo - r) / s)],  G(x) = x Phi(x) + phi(x).

The log Bayes factor of head against hand (:func:`head_log_bayes_factor`) is graded into rule
units (:func:`size_cost`): a name costs ``SIZE_RULE * min(1, ln B_against / ln 3)``, the full rule
once the factor against it reaches 3, the bound above which Jeffreys' scale calls evidence
more than "barely worth mentioning" (Jeffreys, Theory of Probability, 3rd ed. 1961, App. B;
Kass & Raftery, JASA 90:773, 1995, sec. 3.2). The hard limits this replaces (head at least 38
mm, hand at most 42 mm) gave a full rule against any name past them however uncertain the
reading, and nothing in between: a still head 2.2 m away through the wide cameras (a 3 px
blob) read 41 mm, between the two, and was never named.
"""

from __future__ import annotations

import math

HEAD_RADIUS_M = (0.0474, 0.0523)
"""The avatar head's true sigma radius (m): from the front to from the side."""
HAND_RADIUS_M = (0.0157, 0.0300)
"""A hand's true sigma radius (m): end-on to palm-on."""
SIZE_PX_SD = 0.5
"""Standard deviation of a blob's sigma radius in pixels."""
SIZE_SD_FLOOR_M = 0.002
"""Standard deviation of a reading that does not scale with depth (m)."""
FULL_LOG_BF = math.log(3.0)
"""The log Bayes factor against a name at which it costs the full size rule (Jeffreys)."""
_SQRT2 = math.sqrt(2.0)
_INV_SQRT2PI = 1.0 / math.sqrt(2.0 * math.pi)


def _phi(x: float) -> float:
    return _INV_SQRT2PI * math.exp(-0.5 * x * x)


def _cdf(x: float) -> float:
    return 0.5 * math.erfc(-x / _SQRT2)


def radius_sd_m(depth_m: float, fx_px: float, px_sd: float = SIZE_PX_SD,
                floor_m: float = SIZE_SD_FLOOR_M) -> float:
    """``s(z) = sqrt(s0^2 + (s_px z / f)^2)``: a sigma-radius reading's standard deviation (m)
    at depth ``depth_m`` through a camera of focal length ``fx_px``."""
    return math.hypot(floor_m, px_sd * depth_m / fx_px)


def size_log_likelihood(radius_m: float, sd_m: float, lo: float, hi: float,
                        lower_bound: bool = False) -> float:
    """log of the density of a reading ``radius_m`` of a true radius uniform on ``[lo, hi]``
    plus N(0, ``sd_m``^2) noise; ``lower_bound``: log P(reading of the whole >= radius_m)."""
    w = hi - lo
    if lower_bound:
        def g(x: float) -> float:
            return x * _cdf(x) + _phi(x)
        p = sd_m / w * (g((hi - radius_m) / sd_m) - g((lo - radius_m) / sd_m))
    else:
        p = (_cdf((radius_m - lo) / sd_m) - _cdf((radius_m - hi) / sd_m)) / w
    return math.log(max(p, 1e-300))


def head_log_bayes_factor(radius_m: float, sd_m: float, clipped: bool = False) -> float:
    """``ln p(r | head) - ln p(r | hand)`` of a reading (see the module docstring)."""
    return (size_log_likelihood(radius_m, sd_m, *HEAD_RADIUS_M, clipped)
            - size_log_likelihood(radius_m, sd_m, *HAND_RADIUS_M, clipped))


def size_cost(is_head: bool, radius_m: float, sd_m: float, clipped: bool = False,
              unit: float = 1.0) -> float:
    """Rule cost of naming a blob of this reading the head (``is_head``) or a hand: ``unit *
    min(1, ln B_against / ln 3)``, 0 when the evidence favours the name. NaN radius: 0 (no
    evidence)."""
    if not math.isfinite(radius_m) or not math.isfinite(sd_m) or sd_m <= 0.0:
        return 0.0
    llr = head_log_bayes_factor(radius_m, sd_m, clipped)
    against = -llr if is_head else llr
    return unit * min(1.0, max(0.0, against / FULL_LOG_BF))
