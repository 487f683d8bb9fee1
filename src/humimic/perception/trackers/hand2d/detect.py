"""Starting the hand tracker "when the detectors agree" (Menezes sec. 5.1).

OpenCV ships no hand cascade, so the agreement is between skin blobs (sec. 4.2.2), the Haar
face detector (a skin blob on a detected face is not a hand) and the hand template: a blob is
a hand when the template placed on it (three widths around the blob's, five angles) lies
within ``init_edge_px`` mean edge distance. Among agreeing blobs the one whose box holds the
most moving edges wins (Menezes' hands wave), then the best template fit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from humimic.perception.cues.edges import dt_distance
from humimic.perception.cues.importance import Blobs, skin_blobs
from humimic.perception.cues.templates import Template

SCALES = (0.8, 0.95, 1.1)
ANGLES = (-0.6, -0.3, 0.0, 0.3, 0.6)
HAND_ASPECT = (1.0, 3.0)
"""Height / width of a hand's skin blob (palm-on: 1.78; wrist and turned hands vary)."""


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


def candidate_states(center: np.ndarray, width: float) -> np.ndarray:
    """Hand states tried on a blob: its centre, widths ``SCALES x width``, angles
    ``ANGLES`` ``(len(SCALES) * len(ANGLES), 4)``."""
    k, a = np.meshgrid(SCALES, ANGLES, indexing="ij")
    n = k.size
    return np.column_stack([np.full(n, center[0]), np.full(n, center[1]),
                            width * k.ravel(), a.ravel()])


def detect_hands(skin_mask: np.ndarray, dt: np.ndarray, moving: np.ndarray,
                 template: Template, min_hand_px: float, init_edge_px: float,
                 is_face: Callable[[np.ndarray], bool] | None = None) -> Detection:
    """Hand candidates from a full-image skin mask, distance transform and moving-edge image
    (all the image's size). ``is_face(box)`` is asked only about blobs the template agrees
    with (the face detector is the costly part)."""
    blobs = skin_blobs(skin_mask, subsample=2, min_area_px=min_hand_px**2,
                       aspect=HAND_ASPECT)
    keep = blobs.boxes[:, 2] >= min_hand_px
    states, dist, mov = [], [], []
    for c, box in zip(blobs.centers[keep], blobs.boxes[keep], strict=True):
        cand = candidate_states(c, min(box[2], box[3] / 1.78))
        d = dt_distance(dt, template.place(cand)[0])
        i = int(np.argmin(d))
        if d[i] <= init_edge_px and (is_face is None or not is_face(box)):
            x, y, w, h = box.astype(int)
            states.append(cand[i])
            dist.append(d[i])
            mov.append(float((moving[y:y + h, x:x + w] > 0).mean()))
    return Detection(np.array(states).reshape(-1, 4), np.array(dist), np.array(mov), blobs)
