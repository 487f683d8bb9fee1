"""The cue images every model-based tracker computes once per frame (edges and their distance
transforms, moving edges, skin posterior, quantised colours), shared by GEST and TBP."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.maths.jit import njit
from humimic.perception.cues.color_models import ColorLUT, load_posterior_kernels, lut_index
from humimic.perception.cues.edges import edge_maps, strongest_channel_sobel
from humimic.perception.cues.histograms import (
    QuantizedImage,
    chromaticity,
    patch_histograms,
    quantize,
)
from humimic.perception.cues.motion import MotionEdgeMaps, motion_edge_maps, moving_edges
from humimic.sensors.camera_model import CameraImage, Intrinsics


@dataclass(frozen=True)
class FrameCues:
    """One camera frame's cue images, computed once per frame for all particles."""

    intrinsics: Intrinsics
    T_cam_base: np.ndarray
    maps: MotionEdgeMaps
    """Canny edges, moving edges (empty without optical flow) and their distance transforms."""
    skin: np.ndarray | None
    """float32 skin posterior per pixel (None without a skin model)."""
    qimage: QuantizedImage
    edge_density: float
    """Fraction of edge pixels."""

    @property
    def dt(self) -> np.ndarray:
        return self.maps.dt


def frame_cues(frame: CameraImage, bins: int, lut: ColorLUT | None = None,
               flow: np.ndarray | None = None, colour_edges: bool = False,
               colours: str = "rgb") -> FrameCues:
    """The cue images of ``frame``: edges (on the colour gradient with ``colour_edges``; and
    moving edges with ``flow``), skin posterior, quantised colours (``colours``: ``rgb``, or
    ``chromaticity``: normalised rgb, :func:`humimic.perception.cues.histograms.chromaticity`);
    the skin posterior and the rgb bins in one pass (:func:`skin_and_bins`)."""
    maps = edge_maps(frame.image, colour=colour_edges)
    if lut is not None and colours == "rgb" and frame.image.ndim == 3 and not 256 % bins:
        h, w = frame.image.shape[:2]
        skin, planes = skin_and_bins(frame.image, lut.post_table, lut.bits, bins)
        qimage = QuantizedImage(planes, h, w, bins)
    else:
        skin = None if lut is None else lut.posterior(frame.image)
        qimage = quantize(chromaticity(frame.image) if colours == "chromaticity"
                          else frame.image, bins)
    return FrameCues(frame.camera.intrinsics, frame.camera.T_cam_base,
                     motion_edge_maps(maps, flow), skin, qimage,
                     cv2.countNonZero(maps.edges) / maps.edges.size)


@njit
def skin_and_bins(image: np.ndarray, post_table: np.ndarray, bits: int, bins: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`ColorLUT.posterior` (its ``post_table`` at ``bits`` per channel) and
    :func:`~humimic.perception.cues.histograms.quantize`'s planes (``bins`` dividing 256) of
    an RGB uint8 image in one compiled pass (two numpy passes with their temporaries cost
    several times more on the small cue boxes)."""
    h, w = image.shape[0], image.shape[1]
    step = 256 // bins
    skin = np.empty((h, w), np.float32)
    planes = np.empty((3, h * w + 1), np.int32)
    for y in range(h):
        for x in range(w):
            r, g, b = image[y, x, 0], image[y, x, 1], image[y, x, 2]
            skin[y, x] = post_table[lut_index(r, g, b, bits)]
            i = y * w + x
            planes[0, i] = r // step
            planes[1, i] = g // step + (bins + 1)
            planes[2, i] = b // step + 2 * (bins + 1)
    for c in range(3):
        planes[c, h * w] = bins + c * (bins + 1)
    return skin, planes


def load_kernels(lut: ColorLUT | None, bins: int) -> None:
    """Compile the cue kernels -- the strongest channel's gradient, the moving edges, the
    patches' colour counts, the skin posterior (of a whole image and of a strided view:
    :func:`~humimic.perception.cues.color_models.load_posterior_kernels`), with ``lut`` the
    skin posterior and colour bins in one pass -- (or load them from numba's disk cache:
    0.1-0.5 s) now, on a tiny frame, so that a stage's first timed frame does not pay for it
    (every other argument is converted to the one specialisation they are compiled for)."""
    img = np.zeros((2, 2, 3), np.uint8)
    strongest_channel_sobel(img)
    moving_edges(np.zeros((2, 2), np.uint8), np.zeros((2, 2, 2), np.float32))   # DIS: float32
    load_posterior_kernels()
    if not 256 % bins:
        patch_histograms(quantize(img, bins), np.zeros((1, 3)), np.zeros((1, 4)), 2)
        if lut is not None:
            skin_and_bins(img, lut.post_table, lut.bits, bins)
