"""The camera model for one point, compiled (:mod:`humimic.maths.jit`) for the trackers'
per-particle kernels; :class:`~humimic.sensors.camera_model.Intrinsics` stays the public,
vectorised implementation and the reference this is tested against. Inlined into its callers
(``inline="always"``, as :mod:`humimic.bodymodel.geometry_kernels`)."""

from __future__ import annotations

from humimic.maths.jit import njit


@njit(inline="always")
def distort_point(fx, fy, cx, cy, k1, k2, x, y):
    """:meth:`~humimic.sensors.camera_model.Intrinsics.distort` of one undistorted normalised
    point ``(x, y)``: raw pixels ``(u, v)`` (radial model ``s = 1 + k1 r^2 + k2 r^4``)."""
    r2 = x * x + y * y
    s = 1.0 + r2 * (k1 + k2 * r2)
    return fx * x * s + cx, fy * y * s + cy
