"""Shape and motion combined (Menezes sec. 4.1.2): moving edges are preferred to static ones.

Moving edges are the Canny edges where OpenCV's dense optical flow (DIS, "ultrafast" preset)
between the previous and the current frame exceeds ``min_flow_px``. Then, vectorised over
all particles:

* eq. 4 -- :func:`motion_normal_distance`: along each model point's normal the nearest edge
  costs its distance, plus ``rho`` if it is static: ``D = mean_j |x(j) - z(j)| + rho
  gamma(z(j))`` with ``z(j)`` the edge of least cost.
* eq. 5 -- :func:`motion_dt_distance`: two distance transforms, of all edges and of moving
  edges only: ``D = mean_j min(I_DT(j), K I'_DT(j))``, ``K <= 1`` making moving edges more
  attractive.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.maths.jit import njit
from humimic.perception.cues.edges import (
    DT_CAP_PX,
    EdgeMaps,
    _reduce,
    distance_transform,
    grey,
    least_cost_along_normal,
    remap_uv,
)


class OpticalFlow:
    """Dense optical flow (OpenCV DIS) between consecutive grey frames, ``(H, W, 2)`` px."""

    def __init__(self, preset: int = cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST):
        self._dis = cv2.DISOpticalFlow_create(preset)

    def __call__(self, previous: np.ndarray, current: np.ndarray) -> np.ndarray:
        return self._dis.calc(grey(previous), grey(current), None)


@dataclass(frozen=True)
class MotionEdgeMaps:
    """One frame's edges, moving edges and both distance transforms."""

    edges: np.ndarray
    moving: np.ndarray
    """uint8 0/255: the edges whose optical flow is at least ``min_flow_px``."""
    dt: np.ndarray
    dt_moving: np.ndarray


def moving_edges(edges: np.ndarray, flow: np.ndarray, min_flow_px: float = 0.5) -> np.ndarray:
    """The edge pixels whose flow vector is at least ``min_flow_px`` long ("nonzero norm"):
    uint8 0/255, the squared length in the flow's dtype against ``min_flow_px**2`` in it (as
    numpy compares a float32 array with a Python float), in one compiled pass."""
    flow = np.asarray(flow)
    if flow.dtype not in (np.float32, np.float64):
        flow = flow.astype(np.float64)
    return _moving_edges(np.asarray(edges), flow, flow.dtype.type(min_flow_px**2))


@njit
def _moving_edges(edges, flow, min_speed2):
    h, w = edges.shape
    out = np.empty((h, w), np.uint8)
    for y in range(h):
        for x in range(w):
            fx, fy = flow[y, x, 0], flow[y, x, 1]
            out[y, x] = 255 if edges[y, x] > 0 and fx * fx + fy * fy >= min_speed2 else 0
    return out


def motion_edge_maps(maps: EdgeMaps, flow: np.ndarray | None, min_flow_px: float = 0.5,
                     cap: float = DT_CAP_PX) -> MotionEdgeMaps:
    """Add the moving edges and their distance transform to a frame's edge maps (no flow, as
    on the first frame: nothing moves)."""
    if flow is None:                 # no moving edge: the transform is the cap everywhere
        return MotionEdgeMaps(maps.edges, np.zeros_like(maps.edges), maps.dt,
                              np.full(maps.edges.shape, cap, np.float32))
    moving = moving_edges(maps.edges, flow, min_flow_px)
    return MotionEdgeMaps(maps.edges, moving, maps.dt, distance_transform(moving, cap))


def motion_dt_distance(maps: MotionEdgeMaps, points: np.ndarray, K: float = 0.5,
                       cap: float = DT_CAP_PX, reduce: str = "mean") -> np.ndarray:
    """Menezes eq. 5: ``D = (1/N_p) sum_j min(I_DT(j), K I'_DT(j))``, points ``(N, N_p, 2)``."""
    both = np.stack([maps.dt, maps.dt_moving], axis=-1)
    v = sample_pair(both, points, cap)
    return _reduce(np.minimum(v[..., 0], K * v[..., 1]), reduce)  # Menezes eq. 5


def sample_pair(image2: np.ndarray, points: np.ndarray, outside: float) -> np.ndarray:
    """Bilinear samples of a 2-channel float image at points ``(..., 2)`` -> ``(..., 2)``."""
    pts = np.asarray(points)
    out = remap_uv(np.ascontiguousarray(image2, dtype=np.float32), pts[..., 0], pts[..., 1],
                   (float(outside), float(outside)), cv2.INTER_LINEAR)
    return out.astype(np.float64)


def motion_normal_distance(maps: MotionEdgeMaps, points: np.ndarray, normals: np.ndarray,
                           rho: float, search_px: int = 15, reduce: str = "mean") -> np.ndarray:
    """Menezes eq. 4: ``D = (1/N_p) sum_j |x(j) - z(j)| + rho gamma(z(j))`` with ``gamma`` 1
    for a static edge, 0 for a moving one, and ``z(j)`` the edge on the normal of least cost;
    a point with no edge within ``search_px`` costs ``search_px + rho``.

    One gather of an edge code (0 none, 1 static, 2 moving) at every probe; each probe costs
    its offset, plus ``rho`` on a static edge, ``inf`` off the edges."""
    cost_of_code = np.full(256, np.inf)
    cost_of_code[1], cost_of_code[2] = rho, 0.0
    cost = least_cost_along_normal(edge_code(maps.edges, maps.moving), points, normals,
                                   search_px, cost_of_code)  # eq. 4
    return _reduce(np.minimum(cost, search_px + rho), reduce)


@njit
def edge_code(edges: np.ndarray, moving: np.ndarray) -> np.ndarray:
    """uint8 ``(edges > 0) + (moving > 0)`` per pixel (0 none, 1 static edge, 2 moving) in one
    compiled pass."""
    h, w = edges.shape
    out = np.empty((h, w), np.uint8)
    for y in range(h):
        for x in range(w):
            out[y, x] = np.uint8(edges[y, x] > 0) + np.uint8(moving[y, x] > 0)
    return out


__all__ = ["MotionEdgeMaps", "OpticalFlow", "edge_code", "motion_dt_distance", "motion_edge_maps",
           "motion_normal_distance", "moving_edges", "sample_pair"]
