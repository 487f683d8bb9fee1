"""Same seed, same numbers across processes: a short kpf tracking (the Table 1 scenario's ``kpf``
and ``kpf_paper`` configurations at 400 particles -- past ``DEDUP_MIN``, so the deduplicated
float32 kernel sums run -- and CONDENSATION, on a rasterised person whose right arm moves) in
two fresh Python processes gives bit-identical modes, particles and weights, although the
second process runs under different conditions: another hash seed (dict/set order), OpenBLAS
and OpenCV on one thread (reduction order that depends on the thread count), a perturbed heap
(results that depend on an array's address or alignment). Before the fix, OpenCV's IPP
``cv2.magnitude`` in the edge cue's maps made the modes differ at ~1e-9 (relative) after two
frames. (Measured too, not tested here for its ~20 s: numba's kernels compiled in the process
rather than loaded from the cache give the same bits.)"""

from __future__ import annotations

from _repro import outputs_in_two_processes

CHILD = """
    import hashlib
    from _kpf_synth import INTRINSICS, camera, painted_person, static_pose
    from humimic.paths import SCENARIOS_DIR
    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model
    from humimic.perception.trackers.kpf.frame_cues import FrameCues
    from humimic.perception.trackers.kpf.tracker import KpfTracker, kpf_body
    from humimic.scenario import load_scenario

    shift_heap()
    body, T, q0 = kpf_body(), camera(), static_pose()
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    frames = []
    for k in range(3):                       # the right arm raised further each frame
        q = q0.copy()
        q[7] += 0.08 * k
        q[9] -= 0.05 * k
        frames.append(painted_person(body, q, T))
    h = hashlib.sha256()
    for name in ("kpf", "kpf_paper", "condensation"):
        cfg = load_scenario(SCENARIOS_DIR / "schmidt_table1.yaml").trackers[name]
        cfg = cfg.model_copy(update={"n_particles": 400, "iterations": 2})
        tr = KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(3))
        kw = {"colour_gradients": cfg.colour_gradients}
        tr.start(q0, FrameCues(frames[0], lut, **kw), T)
        for img in frames[1:]:
            res = tr.step(FrameCues(img, lut, **kw), T)
            shift_heap()
            for a in (res.mode, res.particles, res.weights):
                h.update(np.ascontiguousarray(a, float).tobytes())
        print(name, repr(res.mode[6:10].tolist()))
    print(h.hexdigest())
"""


def test_kpf_tracking_is_bit_identical_across_processes():
    a, b = outputs_in_two_processes(CHILD)
    assert a == b
