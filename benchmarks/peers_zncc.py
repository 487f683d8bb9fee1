"""Our ZNCC (``humimic.perception.blobs.zncc``) vs ``cv2.matchTemplate(TM_CCOEFF_NORMED)``.

Same inputs, from a rendered stereo frame of the wave: a 13x13 colour template around the
waving hand in the left image, searched in the right image over (a) a 13-row strip 120 px wide
(the stereo case: one output row; ours is ``zncc_map``'s strip path), (b) a 61x61 window
(2-D). OpenCV's colour TM_CCOEFF_NORMED subtracts each channel's mean and sums over channels,
which is Ude's eq. 10 as we compute it, so the score maps must agree (asserted to 1e-3 of a
score in [-1, 1]; both use float32 products) before anything is timed. Also: the batched
strips of 4 targets (``zncc_strips``, what stereo calls) vs 4 matchTemplate calls.
"""

from __future__ import annotations

import cv2
import numpy as np
from _harness import Peer, per_call, row

HALF = 6


def cases(seq):
    """(name, search, template, batch) from the first frames of a rendered stereo sequence."""
    L, R = seq.cameras
    frame = 30
    il, ir = seq.images[L][frame], seq.images[R][frame]
    u, v = np.round(seq.gt_uv[L][frame, 1]).astype(int)
    ur, vr = np.round(seq.gt_uv[R][frame, 1]).astype(int)
    tpl = np.ascontiguousarray(il[v - HALF:v + HALF + 1, u - HALF:u + HALF + 1])
    x0 = max(0, ur - 60)
    strip = np.ascontiguousarray(ir[vr - HALF:vr + HALF + 1, x0:x0 + 120])
    win = np.ascontiguousarray(ir[vr - 30:vr + 31, ur - 30:ur + 31])
    return [("strip 13x120 (stereo)", strip, tpl), ("window 61x61", win, tpl)], (strip, tpl)


def check(ours: np.ndarray, peer: np.ndarray, name: str) -> float:
    diff = float(np.abs(ours - peer).max())
    assert ours.shape == peer.shape and diff < 1e-3, f"ZNCC {name}: differs from cv2 by {diff}"
    return diff


def bench_zncc_peers(repeats: int, seq) -> list[Peer]:
    from humimic.perception.blobs.zncc import zncc_map, zncc_strips

    out = []
    cs, (strip, tpl) = cases(seq)
    for name, search, template in cs:
        diff = check(zncc_map(search, template),
                     cv2.matchTemplate(search, template, cv2.TM_CCOEFF_NORMED).astype(float),
                     name)
        ours = row("perception", f"ZNCC {name} (ours)",
                   per_call(lambda s=search, t=template: zncc_map(s, t), repeats, 200),
                   "us", 1e6)
        peer = row("perception", f"cv2.matchTemplate {name}",
                   per_call(lambda s=search, t=template: cv2.matchTemplate(
                       s, t, cv2.TM_CCOEFF_NORMED), repeats, 200), "us", 1e6)
        out.append(Peer("perception", f"ZNCC per match, {name}: ours vs cv2.matchTemplate",
                        ours, peer, note=f"13x13 RGB template; scores agree to {diff:.0e}"))
    strips = np.repeat(strip[None], 4, 0)
    tpls = np.repeat(tpl[None], 4, 0)
    diff = check(zncc_strips(strips, tpls)[0],
                 cv2.matchTemplate(strip, tpl, cv2.TM_CCOEFF_NORMED)[0].astype(float), "batch")
    ours = row("perception", "ZNCC 4 strips batched (ours)",
               per_call(lambda: zncc_strips(strips, tpls), repeats, 200), "us", 1e6)
    peer = row("perception", "cv2.matchTemplate x 4 strips",
               per_call(lambda: [cv2.matchTemplate(s, t, cv2.TM_CCOEFF_NORMED)
                                 for s, t in zip(strips, tpls, strict=True)], repeats, 200),
               "us", 1e6)
    out.append(Peer("perception", "ZNCC 4 stereo strips: ours batched vs 4 matchTemplate",
                    ours, peer, note=f"as stereo.match_many calls it; agree to {diff:.0e}"))
    return out
