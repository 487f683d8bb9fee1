"""Per-frame cost of the perception core: EM (1, 2, 4 blobs), stereo (4 targets), filters.

Run from the project root: ``python benchmarks/bench_perception.py``
"""
import sys, time
import numpy as np
sys.path.insert(0, "tests")
from _synth_vision import SKIN_RGB, add_noise, clutter_background, draw_ellipse, stereo_head
from humimic.perception.color_models import ColorLUT, fit_color_model
from humimic.perception.em_blobs import BlobTracker, EMParams
from humimic.perception.stereo import StereoRig
from humimic.estimation.random_jerk import RandomJerkFilter, predict, update, initial_state

rng = np.random.default_rng(0)
patch = add_noise(np.full((60, 60, 3), SKIN_RGB, np.uint8), rng, 4.0)
lut = ColorLUT(fit_color_model(patch.reshape(-1, 3), "rgb", 1, np.random.default_rng(1)))
cam_l, cam_r = stereo_head()
from _synth_vision import TexturedPlane
wall = TexturedPlane(np.random.default_rng(2), origin=(3.0, 0.0, 1.2), e1=(0, -1, 0), e2=(0, 0, -1), size_m=4.0, tex_px=800)
bg_l, bg_r = wall.render(cam_l), wall.render(cam_r)  # a textured wall 3 m away
base = np.array([[1.0, 0.25, 1.35], [1.0, -0.25, 1.35], [1.1, 0.2, 1.0], [1.1, -0.2, 1.0]])
axes = [(10, 7), (8, 12), (14, 9), (9, 9)]
N = 240

def pts(f):
    return base + 0.1 * np.sin(2 * np.pi * f / 90 + np.arange(4)[:, None] + np.array([0, 1.1, 2.2]))

frames = []
for f in range(N):
    P = pts(f)
    il, ir = bg_l.copy(), bg_r.copy()
    for k in range(4):
        draw_ellipse(il, cam_l.project_base(P[k]), axes[k], 20 * k)
        draw_ellipse(ir, cam_r.project_base(P[k]), axes[k], 20 * k)
    frames.append((add_noise(il, rng, 4.0), add_noise(ir, rng, 4.0)))

def bench_em(K):
    trs = [BlobTracker([lut] * K), BlobTracker([lut] * K)]
    for tr, cam in zip(trs, (cam_l, cam_r)):
        for k in range(K):
            tr.start(k, cam.project_base(pts(0)[k]), 25 * np.eye(2))
    ts = []
    for il, ir in frames:
        t0 = time.perf_counter(); trs[0].update(il); ts.append(time.perf_counter() - t0)
        trs[1].update(ir)
    return np.median(ts[10:]) * 1e6

for K in (1, 2, 4):
    print(f"EM tracker, {K} blob(s), one 320x240 image: {bench_em(K):7.1f} us")

# full stereo frame: EM on both images, rig, stereo matching, 4 filters
trl, trr = BlobTracker([lut] * 4), BlobTracker([lut] * 4)
for k in range(4):
    trl.start(k, cam_l.project_base(pts(0)[k]), 25 * np.eye(2))
    trr.start(k, cam_r.project_base(pts(0)[k]), 25 * np.eye(2))
filters = [RandomJerkFilter() for _ in range(4)]
C = np.array([[0.65, -0.02], [-0.02, 0.67]])
parts = {"em_left": [], "em_right": [], "rig": [], "stereo": [], "filters": [], "total": []}
errs = []
for f, (il, ir) in enumerate(frames):
    t = f / 60
    t0 = time.perf_counter()
    fl = trl.update(il); t1 = time.perf_counter()
    fr = trr.update(ir); t2 = time.perf_counter()
    rig = StereoRig(cam_l, cam_r); t3 = time.perf_counter()
    ms = rig.match_many(il, ir, fl.centres, fl.covs, fr.centres, fr.covs, C, C); t4 = time.perf_counter()
    for kf, m in zip(filters, ms):
        kf.step(t, m.p_base if m.ok else None, m.R_base if m.ok else None)
    t5 = time.perf_counter()
    for key, a, b in (("em_left", t0, t1), ("em_right", t1, t2), ("rig", t2, t3),
                      ("stereo", t3, t4), ("filters", t4, t5), ("total", t0, t5)):
        parts[key].append(b - a)
    if f > 10:
        errs.append([np.linalg.norm(m.p_base - p) if m.ok else np.nan for m, p in zip(ms, pts(f))])
for key, v in parts.items():
    print(f"{key:9s} median {np.median(v[10:]) * 1e6:7.1f} us")
tot = np.median(parts["total"][10:])
print(f"=> {1 / tot:.0f} stereo frames/s of compute (4 blobs, 320x240)")
errs = np.array(errs)
print("raw 3-D error (mm): median", np.nanmedian(errs) * 1e3, "fail rate", np.isnan(errs).mean())

# batched filter alternative
x, P = initial_state(np.zeros(3), np.eye(3) * 1e-4)
xb, Pb = np.repeat(x[None], 4, 0), np.repeat(P[None], 4, 0)
z, R = np.zeros((4, 3)), np.repeat(np.eye(3)[None] * 1e-4, 4, 0)
t0 = time.perf_counter()
for _ in range(2000):
    xb, Pb = update(*predict(xb, Pb, 1 / 60, 27.5), z, R)
print(f"filters batched (4 targets, predict+update): {(time.perf_counter() - t0) / 2000 * 1e6:.1f} us")
