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
from humimic.perception.cues.color_models import lut_index

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
    labels = np.zeros((h, w), np.int32)
    parent = np.empty(h * ((w + 1) // 2) + 2, np.int32)
    parent[0] = 0
    nprov = 0
    ylo, yhi, xlo, xhi = h, -1, w, -1       # the skin pixels' box: the later passes' extent
    for y in range(h):                      # first pass: mask, provisional labels, unions
        row = image[y0 + y * step]
        for x in range(w):
            px = row[x0 + x * step]
            if mask_table[lut_index(px[0], px[1], px[2], bits)] == 0:
                continue
            ylo, yhi, xlo, xhi = min(ylo, y), max(yhi, y), min(xlo, x), max(xhi, x)
            # 8-neighbours seen so far: W, NW, N, NE; N touches the other three, and W NW
            north = labels[y - 1, x] if y > 0 else 0
            if north > 0:
                labels[y, x] = north
                continue
            west = labels[y, x - 1] if x > 0 else 0
            if west == 0 and x > 0 and y > 0:
                west = labels[y - 1, x - 1]
            east = labels[y - 1, x + 1] if y > 0 and x + 1 < w else 0
            if west > 0 and east > 0:
                a, b = _root(parent, west), _root(parent, east)
                if a < b:
                    parent[b] = a
                elif b < a:
                    parent[a] = b
                labels[y, x] = west
            elif west > 0 or east > 0:
                labels[y, x] = max(west, east)
            else:
                nprov += 1
                parent[nprov] = nprov
                labels[y, x] = nprov
    for i in range(1, nprov + 1):           # every label to its root (the smallest label)
        parent[i] = parent[parent[i]]
    final = np.zeros(nprov + 1, np.int32)
    n = 0
    for by in range(ylo - ylo % 2, yhi + 1, 2):   # numbered in OpenCV's 2 x 2 block scan order
        for bx in range(xlo - xlo % 2, xhi + 1, 2):
            for y in range(by, min(by + 2, h)):
                for x in range(bx, min(bx + 2, w)):
                    r = parent[labels[y, x]]
                    if r > 0 and final[r] == 0:
                        n += 1
                        final[r] = n
    for i in range(1, nprov + 1):
        final[i] = final[parent[i]]
    stats = np.zeros((n + 1, 7), np.int64)
    lo = np.full((n + 1, 2), 1 << 30, np.int64)
    hi = np.full((n + 1, 2), -1, np.int64)
    for y in range(ylo, yhi + 1):
        for x in range(xlo, xhi + 1):
            if labels[y, x] > 0:
                k = final[labels[y, x]]
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


@njit
def measure_blobs(image: np.ndarray, oy: int, ox: int, h: int, w: int, mask_table: np.ndarray,
                  bits: int, s: int, min_area_px: float, aspect_lo: float, aspect_hi: float,
                  grow: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """:func:`.blobs.hand_blobs` (its docstring, and the module's): the components of the
    skin mask subsampled by ``s`` of at least ``min_area_px`` (subsampled px) with a box's
    height/width within ``aspect_lo, aspect_hi`` (:func:`~humimic.perception.cues.importance.
    skin_blobs`), each re-measured at full resolution in its box grown by ``s`` (and by
    ``grow`` times its larger side while the component reaches the box's edge). Returns the
    hull centroids ``(K, 2)``, boxes ``(K, 4)`` and hull areas ``(K,)`` (pixels of the box
    ``image[oy:oy + h, ox:ox + w]`` the blobs are looked for in) and the number of subsampled
    blobs."""
    _, coarse = skin_components(image, oy, oy + h, ox, ox + w, s, mask_table, bits)
    centres = np.empty((len(coarse), 2))
    boxes = np.empty((len(coarse), 4), np.int64)
    areas = np.empty(len(coarse))
    nk, ncoarse = 0, 0
    for c in range(1, len(coarse)):
        x, y = float(coarse[c, 0]), float(coarse[c, 1])
        bw, bh = float(coarse[c, 2]), float(coarse[c, 3])
        ratio = bh / max(bw, 1.0)
        if not (float(coarse[c, 4]) >= min_area_px and aspect_lo <= ratio <= aspect_hi):
            continue
        ncoarse += 1
        ix0, iy0 = max(int(x * s) - s, 0), max(int(y * s) - s, 0)
        ix1, iy1 = min(int((x + bw) * s) + s, w), min(int((y + bh) * s) + s, h)
        pad = 0
        while True:                     # grow the box while the component reaches its edge
            x0, y0 = max(ix0 - pad, 0), max(iy0 - pad, 0)
            x1, y1 = min(ix1 + pad, w), min(iy1 + pad, h)
            labels, stats = skin_components(image, oy + y0, oy + y1, ox + x0, ox + x1, 1,
                                            mask_table, bits)
            inner = count_in_box(labels, len(stats) - 1, iy0 - y0, iy1 - y0, ix0 - x0,
                                 ix1 - x0)
            inner[0] = 0
            k = int(np.argmax(inner))
            bx, by, cw, ch = stats[k, 0], stats[k, 1], stats[k, 2], stats[k, 3]
            cut = ((bx == 0 and 0 < x0) or (by == 0 and 0 < y0)
                   or (bx + cw == x1 - x0 and x1 < w) or (by + ch == y1 - y0 and y1 < h))
            if not cut or pad >= grow * max(bw, bh) * s or inner[k] == 0:
                break
            pad = int(np.ceil(grow * max(bw, bh) * s))
        if inner[k] == 0:
            continue
        seen = False                    # one component seen as two subsampled blobs
        for j in range(nk):
            seen = seen or (boxes[j, 0] == bx + x0 and boxes[j, 1] == by + y0
                            and boxes[j, 2] == cw and boxes[j, 3] == ch)
        if seen:
            continue
        m00, m10, m01 = hull_sums(labels, k, by, by + ch, bx, bx + cw)
        centres[nk, 0] = m10 / m00 + (x0 + bx)
        centres[nk, 1] = m01 / m00 + (y0 + by)
        boxes[nk, 0], boxes[nk, 1], boxes[nk, 2], boxes[nk, 3] = bx + x0, by + y0, cw, ch
        areas[nk] = m00
        nk += 1
    return centres[:nk], boxes[:nk], areas[:nk], ncoarse
