"""Starting the hand tracker "when the detectors agree" (Menezes sec. 5.1).

OpenCV ships no hand cascade, so the agreement is between skin blobs (sec. 4.2.2), the Haar
face detector (a skin blob on a detected face is not a hand) and the hand template: a blob is
a hand when the template placed on it (three widths around the blob's, five angles about the
blob's long axis) lies within ``init_edge_px`` mean edge distance. Among agreeing blobs the one
whose box holds the most moving edges wins (Menezes' hands wave), then the best template fit.

A hand is found at any in-plane turn: its blob's elongation and long axis come from the
blob's second moments (:func:`blob_axes`), not its box, and the blob must fill the ellipse of
those moments (:data:`HAND_FILL`). With an upright box (height / width
1-3) and angles within 0.6 rad of upright, a hand held across the chest (the palm edge-on, its
long axis horizontal: ``menezes_hand_people`` with ``human.motion.kind: figure8``) was never a
candidate, and the tracker started on the other person's hanging hand at the image's edge and
stayed there: lost on 100 % of the frames, 175 frames on the wrong person.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from humimic.perception.cues.edges import dt_distance
from humimic.perception.cues.importance import Blobs, skin_blobs
from humimic.perception.cues.templates import Template

SCALES = (0.8, 0.95, 1.1)
ANGLES = (-0.6, -0.3, 0.0, 0.3, 0.6)
HAND_ASPECT = (1.0, 3.0)
"""Length / width of a hand's skin blob along its principal axes (palm-on: 1.78; edge-on,
wrist and turned hands vary)."""
HAND_FILL = 0.75
"""Least share of its equal-moment ellipse a hand's skin blob fills (an ellipse 1, a rectangle
0.95, a hand cut by the image's edge 0.82). A hand merged with a look-alike surface fills less:
a very dark hand on lab_clutter's dark-brown bar (menezes_fig5_hand, skin [0.25, 0.16, 0.11],
seed 2) gave one blob 186 x 60 px, 2.6 times longer than wide, filling 0.29 -- the upright-box
rule had refused it by its box; taken, the track started 14 px and 20 px wider off the hand."""
HAND_TEMPLATE_ASPECT = 0.08 / 0.045
"""Length / width of the hand template (:func:`~humimic.perception.cues.templates.hand`)."""


@dataclass(frozen=True)
class Detection:
    states: np.ndarray
    """(K, 4) candidate hand states (u, v, s, theta) of the blobs that passed."""
    distances: np.ndarray
    """(K,) their mean edge distances (px)."""
    moving: np.ndarray
    """(K,) fraction of moving-edge pixels in their boxes."""
    blobs: Blobs
    """Every skin blob (for display)."""

    @property
    def best(self) -> np.ndarray | None:
        if not len(self.states):
            return None
        return self.states[np.lexsort((self.distances, -np.round(self.moving, 2)))[0]]


def face_on_blob(image: np.ndarray, box: np.ndarray, detector, grow: float = 1.0) -> bool:
    """Whether the face detector finds a face whose box holds the blob's centre, searching
    only the blob's box grown by ``grow`` box sizes on every side."""
    x, y, w, h = np.asarray(box, float)
    H, W = image.shape[:2]
    x0, y0 = int(max(0, x - grow * w)), int(max(0, y - grow * h))
    x1, y1 = int(min(W, x + (1 + grow) * w)), int(min(H, y + (1 + grow) * h))
    faces = detector.detect(np.ascontiguousarray(image[y0:y1, x0:x1]))
    cx, cy = x + w / 2 - x0, y + h / 2 - y0
    return bool(np.any((cx >= faces[:, 0]) & (cx <= faces[:, 0] + faces[:, 2])
                       & (cy >= faces[:, 1]) & (cy <= faces[:, 1] + faces[:, 3])))


def blob_axes(mask: np.ndarray) -> tuple[float, float, float]:
    """``(theta, width, length)`` of a blob (a boolean / 0-1 image of its pixels): the
    ellipse of the same second central moments, whose semi-axes are ``2 sqrt(lambda)`` of the
    moments' covariance eigenvalues (a solid ellipse's own); ``theta`` turns the hand
    template's long axis (image +v at ``theta = 0``) onto the blob's, in (-pi/2, pi/2]."""
    m = cv2.moments(np.asarray(mask, np.uint8), binaryImage=True)
    if m["m00"] <= 0:
        return 0.0, 0.0, 0.0
    a, b, c = m["mu20"] / m["m00"], m["mu11"] / m["m00"], m["mu02"] / m["m00"]
    half, mid = np.hypot(0.5 * (a - c), b), 0.5 * (a + c)
    phi = 0.5 * np.arctan2(2.0 * b, a - c)           # the long axis' angle from +u
    theta = phi - 0.5 * np.pi                         # template's +v onto (cos phi, sin phi)
    if theta <= -0.5 * np.pi:
        theta += np.pi
    return (float(theta), 4.0 * np.sqrt(max(mid - half, 0.0)),
            4.0 * np.sqrt(mid + half))


def component_axes(mask: np.ndarray, box: np.ndarray) -> tuple[float, float, float, float]:
    """:func:`blob_axes` of the largest 8-connected skin component inside ``box`` (x, y, w,
    h) of the full-resolution ``mask`` (the blob the subsampled search found), and the share
    of its equal-moment ellipse (area pi width length / 4) its pixels fill."""
    x, y, w, h = np.asarray(box, int)
    crop = np.ascontiguousarray(np.asarray(mask[y:y + h, x:x + w]) > 0, np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(crop, connectivity=8)
    if n < 2:
        return 0.0, 0.0, 0.0, 0.0
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    theta, width, length = blob_axes(labels == k)
    ellipse = 0.25 * np.pi * width * length
    return theta, width, length, (stats[k, cv2.CC_STAT_AREA] / ellipse if ellipse > 0 else 0.0)


def candidate_states(center: np.ndarray, width: float, theta: float = 0.0) -> np.ndarray:
    """Hand states tried on a blob: its centre, widths ``SCALES x width``, angles
    ``theta + ANGLES`` ``(len(SCALES) * len(ANGLES), 4)``."""
    k, a = np.meshgrid(SCALES, ANGLES, indexing="ij")
    n = k.size
    return np.column_stack([np.full(n, center[0]), np.full(n, center[1]),
                            width * k.ravel(), theta + a.ravel()])


def detect_hands(skin_mask: np.ndarray, dt: np.ndarray, moving: np.ndarray,
                 template: Template, min_hand_px: float, init_edge_px: float,
                 is_face: Callable[[np.ndarray], bool] | None = None) -> Detection:
    """Hand candidates from a full-image skin mask, distance transform and moving-edge image
    (all the image's size). ``is_face(box)`` is asked only about blobs the template agrees
    with (the face detector is the costly part)."""
    blobs = skin_blobs(skin_mask, subsample=2, min_area_px=min_hand_px**2,
                       aspect=(0.0, np.inf))
    states, dist, mov = [], [], []
    for c, box in zip(blobs.centers, blobs.boxes, strict=True):
        theta, width, length, fill = component_axes(skin_mask, box)
        if (width < min_hand_px or not HAND_ASPECT[0] <= length / width <= HAND_ASPECT[1]
                or fill < HAND_FILL):
            continue
        cand = candidate_states(c, min(width, length / HAND_TEMPLATE_ASPECT), theta)
        d = dt_distance(dt, template.place(cand)[0])
        i = int(np.argmin(d))
        if d[i] <= init_edge_px and (is_face is None or not is_face(box)):
            x, y, w, h = box.astype(int)
            states.append(cand[i])
            dist.append(d[i])
            mov.append(float((moving[y:y + h, x:x + w] > 0).mean()))
    return Detection(np.array(states).reshape(-1, 4), np.array(dist), np.array(mov), blobs)
