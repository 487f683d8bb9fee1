"""Silhouette templates for the shape cue (Menezes Fig. 1): contour points with normals.

A template is ``N_p`` points spread uniformly along a contour, in *template units*, with unit
normals. :meth:`Template.place` puts it at image states ``(u, v, s[, theta])`` for all
particles at once: ``p_px = (u, v) + s R(theta) p`` -- ``s`` is the size of one template unit
in pixels (the head's width, the hand's width), ``theta`` an in-plane rotation (rad,
clockwise on the image, since v points down). Image axes: u right, v down.

* :func:`head_and_shoulders` -- the "Omega" outline of the ICU tracker (head width = 1, head
  centre at the origin).
* :func:`hand` -- the outline of the avatar's hand seen palm-on: an ellipse (the avatar's hand
  is an ellipsoid, 9 x 16 cm; a template with fingers would not match it). Hand width = 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.maths.jit import njit


@dataclass(frozen=True)
class Template:
    points: np.ndarray
    """``(N_p, 2)`` contour points in template units."""
    normals: np.ndarray
    """``(N_p, 2)`` unit normals at the points."""
    name: str = ""

    def place(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points and normals ``(N, N_p, 2)`` in pixels for states ``(N, 3)`` (u, v, s) or
        ``(N, 4)`` (u, v, s, theta)."""
        x = np.asarray(states, dtype=np.float64)
        x = x[None] if x.ndim == 1 else x
        if x.shape[1] >= 4:   # numpy's cos/sin (numba's libm ones can differ in the last bit)
            return _place_rotated(x, np.cos(x[:, 3]), np.sin(x[:, 3]), self.points,
                                  self.normals)
        else:
            p = np.broadcast_to(self.points, (len(x),) + self.points.shape)
            nrm = np.broadcast_to(self.normals, p.shape)
        return x[:, None, :2] + x[:, 2, None, None] * p, nrm


@njit
def _place_rotated(x, c, s, q, n):
    """:meth:`Template.place` for states ``x (N, >= 4)`` with the cosines/sines ``c, s (N,)``
    of their angles: ``(u, v) + s R q`` and ``R n`` (``R = [[c, -s], [s, c]]``) in one
    compiled pass, each product and sum as numpy's broadcast form rounds it."""
    pts = np.empty((len(x), len(q), 2))
    nrm = np.empty((len(x), len(q), 2))
    for i in range(len(x)):
        for k in range(len(q)):
            pts[i, k, 0] = x[i, 0] + x[i, 2] * (c[i] * q[k, 0] - s[i] * q[k, 1])
            pts[i, k, 1] = x[i, 1] + x[i, 2] * (s[i] * q[k, 0] + c[i] * q[k, 1])
            nrm[i, k, 0] = c[i] * n[k, 0] - s[i] * n[k, 1]
            nrm[i, k, 1] = s[i] * n[k, 0] + c[i] * n[k, 1]
    return pts, nrm


def resample_contour(polyline: np.ndarray, n: int, closed: bool) -> Template:
    """``n`` points uniformly spaced in arc length along a polyline (closed or open), with
    normals from the local tangent (pointing to the right of the direction of travel)."""
    p = np.asarray(polyline, dtype=np.float64)
    if closed:
        p = np.vstack([p, p[:1]])
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    t = (np.arange(n) + 0.5) * total / n if closed else np.linspace(0.0, total, n)
    pts = np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], axis=-1)
    h = 1e-3 * total
    ahead = np.stack([np.interp(t + h, s, p[:, 0], period=total if closed else None),
                      np.interp(t + h, s, p[:, 1], period=total if closed else None)], -1)
    behind = np.stack([np.interp(t - h, s, p[:, 0], period=total if closed else None),
                       np.interp(t - h, s, p[:, 1], period=total if closed else None)], -1)
    tangent = ahead - behind
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normals = np.stack([-tangent[:, 1], tangent[:, 0]], axis=-1)
    return Template(pts, normals)


def _ellipse_arc(a: float, b: float, start_deg: float, stop_deg: float, k: int = 200,
                 center=(0.0, 0.0)) -> np.ndarray:
    t = np.radians(np.linspace(start_deg, stop_deg, k))
    return np.stack([center[0] + a * np.cos(t), center[1] + b * np.sin(t)], axis=-1)


def head_and_shoulders(n_points: int = 15) -> Template:
    """Head and shoulders outline, head width 1, head centre at the origin (v down).

    Head: an ellipse 1 x 1.3 (the avatar's head is 15.6 x 23 cm) from the left side of the jaw
    over the crown to the right; neck 0.6 wide; shoulders sloping out to 1.55 either side of
    the head's axis, 1.3 below its centre.
    """
    head = _ellipse_arc(0.5, 0.65, 120.0, 420.0)  # from lower left, over the top (v down)
    left = np.array([[-1.55, 1.6], [-1.15, 1.05], [-0.32, 0.85]])
    right = left[::-1] * np.array([-1.0, 1.0])
    poly = np.vstack([left, head, right])
    t = resample_contour(poly, n_points, closed=False)
    return Template(t.points, t.normals, "head_and_shoulders")


def hand(n_points: int = 30, aspect: float = 0.08 / 0.045) -> Template:
    """The avatar's hand seen palm-on: an ellipse of width 1 and height ``aspect`` centred on
    the palm (semi-axes 0.045 x 0.08 m in ``models/avatar.xml``)."""
    t = resample_contour(_ellipse_arc(0.5, 0.5 * aspect, 0.0, 360.0, 400)[:-1], n_points,
                         closed=True)
    return Template(t.points, t.normals, "hand")


TEMPLATES = {"head_and_shoulders": head_and_shoulders, "hand": hand}
