"""Same seed, same numbers across processes for GEST: a short tracking (a skin ellipsoid
moving over cluttered walls in a stereo pair) in two fresh processes, the second under other
conditions (:mod:`_repro`), gives bit-identical estimates. Before the fix, OpenCV's IPP exact
distance transform (the shape cue's map, ``cues.edges.distance_transform``) rounded by the
address of its output, which the binding allocates on numpy's heap: the estimates differed
at ~1e-12 (relative)."""

from __future__ import annotations

from _repro import outputs_in_two_processes

CHILD = """
    import hashlib
    from _synth_vision import clutter_background, stereo_head
    from test_trackers_gest_tracking import HAND, _draw
    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model
    from humimic.perception.trackers.gest.config import GestConfig
    from humimic.perception.trackers.gest.tracker import GestTracker

    shift_heap()
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    cams = stereo_head(k1=0.0, k2=0.0)
    bgs = [clutter_background(np.random.default_rng(s)) for s in (4, 5)]
    trk = GestTracker(GestConfig(), lut)
    rng = np.random.default_rng(0)
    h = hashlib.sha256()
    for k in range(4):
        hand = HAND + np.r_[0.0, 0.006 * k, -0.004 * k, 0.05 * k, np.zeros(5)]
        res = trk.step(*_draw(bgs, cams, [hand]), rng)
        shift_heap()
        h.update(res.status.encode())
        for a in (res.mean, res.cov):
            h.update(np.ascontiguousarray(a, float).tobytes())
        print(res.status, repr(res.mean[:3].tolist()))
    print(h.hexdigest())
"""


def test_gest_tracking_is_bit_identical_across_processes():
    a, b = outputs_in_two_processes(CHILD)
    assert a == b
