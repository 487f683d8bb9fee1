"""Our ZNCC (``humimic.perception.blobs.zncc``) vs ``cv2.matchTemplate(TM_CCOEFF_NORMED)``.

Same inputs, from a rendered stereo frame of the wave: a 13x13 colour template around the
waving hand in the left image, searched in the right image along a 13-row strip 120 px wide
(the stereo case: one output row), for one target and for 4 (``zncc_strips`` batches them, as
stereo calls it) vs one ``cv2.matchTemplate`` call per strip. OpenCV's colour TM_CCOEFF_NORMED
subtracts each channel's mean and sums over channels, which is Ude's eq. 10 as we compute it, so
the score maps must agree (asserted to 1e-3 of a score in [-1, 1]; both use float32 products)
before anything is timed. (2-D score maps are ``cv2.matchTemplate``'s: we have none of our own.)
"""

from __future__ import annotations

import cv2
import numpy as np
from _harness import Peer, per_call, row

HALF = 6


def cases(seq):
    """(strip, template) from a frame of a rendered stereo sequence."""
    L, R = seq.cameras
    frame = 30
    il, ir = seq.images[L][frame], seq.images[R][frame]
    u, v = np.round(seq.gt_uv[L][frame, 1]).astype(int)
    ur, vr = np.round(seq.gt_uv[R][frame, 1]).astype(int)
    tpl = np.ascontiguousarray(il[v - HALF:v + HALF + 1, u - HALF:u + HALF + 1])
    x0 = max(0, ur - 60)
    strip = np.ascontiguousarray(ir[vr - HALF:vr + HALF + 1, x0:x0 + 120])
    return strip, tpl


def check(ours: np.ndarray, peer: np.ndarray, name: str) -> float:
    diff = float(np.abs(ours - peer).max())
    assert ours.shape == peer.shape and diff < 1e-3, f"ZNCC {name}: differs from cv2 by {diff}"
    return diff


def bench_zncc_peers(repeats: int, seq) -> list[Peer]:
    from humimic.perception.blobs.zncc import zncc_strips

    out = []
    strip, tpl = cases(seq)
    diff = check(zncc_strips(strip[None], tpl[None])[0],
                 cv2.matchTemplate(strip, tpl, cv2.TM_CCOEFF_NORMED)[0].astype(float), "strip")
    ours = row("perception", "ZNCC strip 13x120 (ours)",
               per_call(lambda: zncc_strips(strip[None], tpl[None]), repeats, 200), "us", 1e6)
    peer = row("perception", "cv2.matchTemplate strip 13x120",
               per_call(lambda: cv2.matchTemplate(strip, tpl, cv2.TM_CCOEFF_NORMED), repeats,
                        200), "us", 1e6)
    out.append(Peer("perception", "ZNCC per match, strip 13x120: ours vs cv2.matchTemplate",
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
