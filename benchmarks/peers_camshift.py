"""Our EM blob tracker vs OpenCV's CamShift on a back-projected skin histogram.

Same rendered frames (the humimic scene, left wide eye camera, 320x240, 60 Hz, pixel noise
2.0), same targets (head and both hands), same start: each tracker starts on frame 0 from the
true visible skin of each target (segmentation mean / covariance; CamShift's window is its
+-2 sigma box). Neither gets help afterwards: this is the bare tracker (our perception stage
adds detection, loss handling and identity on top of the EM tracker). Sequences (3 s,
keyframed): both hands cross in front of the body; the right hand passes in front of the face;
a plain wave.

* EM: :class:`BlobTracker` with the shipped skin colour model (``models/colors/skin.json``).
* CamShift: a hue-saturation histogram (30 x 32 bins) of frame 0's true skin pixels,
  ``calcBackProject`` per frame, one ``cv2.CamShift`` per target (10 iterations / 1 px).

Time per frame covers everything each needs per frame (EM: the update of all blobs;
CamShift: HSV conversion, back-projection, all CamShift calls). The centre error is the
distance (px) between the tracker's centre and the target's true site (palm centre / head
centre) projected into the image, per frame, all targets.
"""

from __future__ import annotations

import time

import cv2
import numpy as np
from _frames import CROSSING_HANDS, HAND_PASSES_FACE, WAVE, render_sequence
from _harness import Peer, row

SEQUENCES = {"hands cross": CROSSING_HANDS, "hand passes face": HAND_PASSES_FACE,
             "wave": WAVE}
LOST_PX = 15.0
TERM = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 1.0)


def em_track(seq, lut) -> tuple[np.ndarray, float]:
    """Centres (frames, targets, 2) and seconds per frame."""
    from humimic.perception.blobs.em_blobs import BlobTracker

    cam = seq.cameras[0]
    K = len(seq.targets)
    tracker = BlobTracker([lut] * K)
    for k in range(K):
        tracker.start(k, seq.mask_mean[cam][0, k], seq.mask_cov[cam][0, k])
    out = np.empty((seq.n_frames, K, 2))
    out[0] = seq.mask_mean[cam][0]
    t0 = time.perf_counter()
    for i in range(1, seq.n_frames):
        out[i] = tracker.update(seq.images[cam][i]).centres
    return out, (time.perf_counter() - t0) / (seq.n_frames - 1)


def skin_histogram(skin_rgb: np.ndarray) -> np.ndarray:
    hsv = cv2.cvtColor(skin_rgb.reshape(-1, 1, 3), cv2.COLOR_RGB2HSV)
    hist = cv2.calcHist([hsv], [0, 1], None, [30, 32], [0, 180, 0, 256])
    return cv2.normalize(hist, hist, 0, 255, cv2.NORM_MINMAX)


def camshift_track(seq, hist) -> tuple[np.ndarray, float]:
    cam = seq.cameras[0]
    K = len(seq.targets)
    H, W = seq.images[cam][0].shape[:2]
    windows = []
    for k in range(K):
        (u, v), sd = seq.mask_mean[cam][0, k], np.sqrt(np.diag(seq.mask_cov[cam][0, k]))
        x0, y0 = int(max(0, u - 2 * sd[0])), int(max(0, v - 2 * sd[1]))
        windows.append((x0, y0, int(min(W - x0, max(2, 4 * sd[0]))),
                        int(min(H - y0, max(2, 4 * sd[1])))))
    out = np.empty((seq.n_frames, K, 2))
    out[0] = seq.mask_mean[cam][0]
    t0 = time.perf_counter()
    for i in range(1, seq.n_frames):
        hsv = cv2.cvtColor(seq.images[cam][i], cv2.COLOR_RGB2HSV)
        prob = cv2.calcBackProject([hsv], [0, 1], hist, [0, 180, 0, 256], 1)
        for k in range(K):
            if windows[k][2] < 1 or windows[k][3] < 1:  # collapsed: lost for good
                out[i, k] = out[i - 1, k]
                continue
            box, windows[k] = cv2.CamShift(prob, windows[k], TERM)
            out[i, k] = box[0]
    return out, (time.perf_counter() - t0) / (seq.n_frames - 1)


def errors(seq, centres: np.ndarray) -> np.ndarray:
    """(frames - 1, targets) centre errors (px) from frame 1 on."""
    gt = seq.gt_uv[seq.cameras[0]]
    return np.linalg.norm(centres[1:] - gt[1:], axis=-1)


def error_stats(err: np.ndarray, targets: list[str]) -> dict:
    per = {t: {"rms_px": float(np.sqrt(np.mean(err[:, k] ** 2))),
               "median_px": float(np.median(err[:, k])),
               "max_px": float(err[:, k].max()),
               "lost_fraction": float((err[:, k] > LOST_PX).mean())}
           for k, t in enumerate(targets)}
    return {"rms_px": float(np.sqrt(np.mean(err**2))), "median_px": float(np.median(err)),
            "lost_fraction": float((err > LOST_PX).mean()), "per_target": per}


def bench_camshift_peers(repeats: int, lut, duration: float = 3.0) -> tuple[list[Peer], dict]:
    peers, accuracy = [], {}
    for name, human in SEQUENCES.items():
        seq = render_sequence(name.replace(" ", "_"), human, duration, cameras="left")
        hist = skin_histogram(seq.skin_pixels)
        em_runs = [em_track(seq, lut) for _ in range(repeats)]
        cs_runs = [camshift_track(seq, hist) for _ in range(repeats)]
        em_err = error_stats(errors(seq, em_runs[0][0]), seq.targets)
        cs_err = error_stats(errors(seq, cs_runs[0][0]), seq.targets)
        accuracy[name] = {"ours_em": em_err, "camshift": cs_err, "frames": seq.n_frames}
        ours = row("perception", f"EM tracker, {name} (ours)", [r[1] for r in em_runs], "us",
                   1e6, **em_err)
        peer = row("perception", f"CamShift, {name}", [r[1] for r in cs_runs], "us", 1e6,
                   **cs_err)
        note = (f"3 targets, {seq.n_frames} frames; centre error RMS / median / lost>"
                f"{LOST_PX:g}px: ours {em_err['rms_px']:.1f} / {em_err['median_px']:.1f} px / "
                f"{em_err['lost_fraction']:.0%}, CamShift {cs_err['rms_px']:.1f} / "
                f"{cs_err['median_px']:.1f} px / {cs_err['lost_fraction']:.0%}")
        peers.append(Peer("perception", f"blob tracking per frame, {name}: EM vs CamShift",
                          ours, peer, note))
    return peers, accuracy
