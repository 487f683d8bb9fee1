"""Compiled kernels for GEST's skin blobs (:mod:`.blobs`): one pass over a box of the image
that builds the skin mask and labels its 8-connected components, and the moments of a
component together with the pixels of its convex hull.

Speed, not new maths: on the small boxes GEST looks in (a hand of 40-70 px, a box of a few
thousand pixels), OpenCV's and numpy's calls and temporaries cost more than the work, so the
mask (``ColorLUT.mask``: a table gather per pixel), the labelling
(``cv2.connectedComponentsWithStats``, 8-connected) and the hull (``cv2.findContours``,
``cv2.convexHull``, Pick's theorem, ``cv2.moments``) are fused into loops compiled with numba.
The results equal OpenCV's exactly (tests): the labels are numbered in the order OpenCV's
block-based labelling (2 x 2 blocks, scanned row-pair by row-pair) first meets the
components, and the moments are integer sums.
"""

from __future__ import annotations

import numpy as np

from humimic.maths.jit import njit

STATS = ("x", "y", "w", "h", "area", "sum_x", "sum_y")
"""The columns of :func:`skin_components`' stats (px, in the labelled grid)."""


@njit
def _root(parent: np.ndarray, i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit
def skin_components(image: np.ndarray, y0: int, y1: int, x0: int, x1: int, step: int,
                    mask_table: np.ndarray, bits: int) -> tuple[np.ndarray, np.ndarray]:
    """The 8-connected components of the skin mask of ``image[y0:y1:step, x0:x1:step]`` (RGB
    uint8; mask ``mask_table[index]`` with :meth:`ColorLUT.index`'s index at ``bits`` per
    channel): labels ``(h, w)`` int32 (0 background, 1..n numbered as OpenCV does) and stats
    ``(n + 1, 7)`` int64 (:data:`STATS`, row 0 unused)."""
    h = (y1 - y0 + step - 1) // step
    w = (x1 - x0 + step - 1) // step
    shift = 8 - bits
    labels = np.zeros((h, w), np.int32)
    parent = np.empty(h * ((w + 1) // 2) + 2, np.int32)
    nprov = 0
    for y in range(h):                      # first pass: mask, provisional labels, unions
        row = image[y0 + y * step]
        for x in range(w):
            px = row[x0 + x * step]
            idx = (((np.int32(px[0]) >> shift) << (2 * bits))
                   | ((np.int32(px[1]) >> shift) << bits) | (np.int32(px[2]) >> shift))
            if mask_table[idx] == 0:
                continue
            lab = 0
            if x > 0 and labels[y, x - 1] > 0:
                lab = labels[y, x - 1]
            if y > 0:
                for dx in (-1, 0, 1):
                    if 0 <= x + dx < w:
                        other = labels[y - 1, x + dx]
                        if other > 0:
                            if lab == 0:
                                lab = other
                            else:
                                a, b = _root(parent, lab), _root(parent, other)
                                if a < b:
                                    parent[b] = a
                                elif b < a:
                                    parent[a] = b
            if lab == 0:
                nprov += 1
                parent[nprov] = nprov
                lab = nprov
            labels[y, x] = lab
    final = np.zeros(nprov + 1, np.int32)
    n = 0
    for by in range(0, h, 2):               # numbered in OpenCV's 2 x 2 block scan order
        for bx in range(0, w, 2):
            for y in range(by, min(by + 2, h)):
                for x in range(bx, min(bx + 2, w)):
                    if labels[y, x] > 0:
                        r = _root(parent, labels[y, x])
                        if final[r] == 0:
                            n += 1
                            final[r] = n
    stats = np.zeros((n + 1, 7), np.int64)
    lo = np.full((n + 1, 2), 1 << 30, np.int64)
    hi = np.full((n + 1, 2), -1, np.int64)
    for y in range(h):
        for x in range(w):
            if labels[y, x] > 0:
                k = final[_root(parent, labels[y, x])]
                labels[y, x] = k
                lo[k, 0] = min(lo[k, 0], x)
                lo[k, 1] = min(lo[k, 1], y)
                hi[k, 0] = max(hi[k, 0], x)
                hi[k, 1] = max(hi[k, 1], y)
                stats[k, 4] += 1
                stats[k, 5] += x
                stats[k, 6] += y
    for k in range(1, n + 1):
        stats[k, 0], stats[k, 1] = lo[k, 0], lo[k, 1]
        stats[k, 2], stats[k, 3] = hi[k, 0] - lo[k, 0] + 1, hi[k, 1] - lo[k, 1] + 1
    return labels, stats


@njit
def count_in_box(labels: np.ndarray, n: int, y0: int, y1: int, x0: int, x1: int
                 ) -> np.ndarray:
    """Pixels of each label ``0..n`` in ``labels[y0:y1, x0:x1]`` (``np.bincount``)."""
    counts = np.zeros(n + 1, np.int64)
    for y in range(max(y0, 0), min(y1, labels.shape[0])):
        for x in range(max(x0, 0), min(x1, labels.shape[1])):
            counts[labels[y, x]] += 1
    return counts


@njit
def _gcd(a: int, b: int) -> int:
    while b:
        a, b = b, a % b
    return a


@njit
def _turn(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> int:
    """The cross product ``(a - o) x (b - o)`` of points ``(x, y)`` in ``(y, x)`` order (the
    order the hull's points are sorted in)."""
    return (a[1] - o[1]) * (b[0] - o[0]) - (a[0] - o[0]) * (b[1] - o[1])


@njit
def hull_sums(labels: np.ndarray, k: int, y0: int, y1: int, x0: int, x1: int
              ) -> tuple[int, int, int]:
    """``(m00, m10, m01)`` of the pixels labelled ``k`` in ``labels[y0:y1, x0:x1]`` and of
    those whose centres lie in their convex hull (:func:`.blobs.hull_moments`), in the box's
    pixels."""
    labels = labels[y0:y1, x0:x1]
    h, w = labels.shape
    rows = np.empty(h, np.int64)
    lefts = np.empty(h, np.int64)
    rights = np.empty(h, np.int64)
    nr = 0
    m00 = m10 = m01 = 0
    for y in range(h):                      # each row's extreme pixels bound the hull
        first, last = -1, -1
        for x in range(w):
            if labels[y, x] == k:
                if first < 0:
                    first = x
                last = x
                m00 += 1
                m10 += x
                m01 += y
        if first >= 0:
            rows[nr], lefts[nr], rights[nr] = y, first, last
            nr += 1
    if nr == 0:
        return 0, 0, 0
    pts = np.empty((2 * nr, 2), np.int64)   # sorted by (y, x)
    npts = 0
    for i in range(nr):
        pts[npts, 0], pts[npts, 1] = lefts[i], rows[i]
        npts += 1
        if rights[i] != lefts[i]:
            pts[npts, 0], pts[npts, 1] = rights[i], rows[i]
            npts += 1
    hull = np.empty((2 * npts + 1, 2), np.int64)   # Andrew's monotone chain, no collinear
    m = 0
    for i in range(npts):
        while m >= 2 and _turn(hull[m - 2], hull[m - 1], pts[i]) <= 0:
            m -= 1
        hull[m] = pts[i]
        m += 1
    lower = m + 1
    for i in range(npts - 2, -1, -1):
        while m >= lower and _turn(hull[m - 2], hull[m - 1], pts[i]) <= 0:
            m -= 1
        hull[m] = pts[i]
        m += 1
    m = max(m - 1, 1)                       # the last point repeats the first
    area2 = 0                               # Pick: pixels in the hull = A + B / 2 + 1
    boundary = 0
    for i in range(m):
        j = (i + 1) % m
        area2 += hull[i, 0] * hull[j, 1] - hull[j, 0] * hull[i, 1]
        boundary += _gcd(abs(hull[j, 0] - hull[i, 0]), abs(hull[j, 1] - hull[i, 1]))
    in_hull = (abs(area2) + boundary) // 2 + 1
    if m00 >= in_hull:                      # the blob has all of them (the common case)
        return m00, m10, m01
    m00 = m10 = m01 = 0
    for y in range(rows[0], rows[nr - 1] + 1):   # per row: the hull's span, as in blobs.py
        left, right = np.inf, -np.inf
        fy = float(y)
        for i in range(m):
            j = (i + 1) % m
            ax, ay, bx, by = float(hull[i, 0]), float(hull[i, 1]), float(hull[j, 0]), float(
                hull[j, 1])
            lo, hi = min(ay, by), max(ay, by)
            if fy < lo - 1e-9 or fy > hi + 1e-9:
                continue
            if hi > lo:
                xe = ax + (fy - ay) / (by - ay) * (bx - ax)
                left, right = min(left, xe), max(right, xe)
            else:
                left, right = min(left, ax, bx), max(right, ax, bx)
        for x in range(w):
            if labels[y, x] == k or (x >= left - 1e-9 and x <= right + 1e-9):
                m00 += 1
                m10 += x
                m01 += y
    return m00, m10, m01
