"""The cue images every model-based tracker computes once per frame (edges and their distance
transforms, moving edges, skin posterior, quantised colours), shared by GEST and TBP."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.edges import edge_maps
from humimic.perception.cues.histograms import QuantizedImage, chromaticity, quantize
from humimic.perception.cues.motion import MotionEdgeMaps, motion_edge_maps
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
    ``chromaticity``: normalised rgb, :func:`humimic.perception.cues.histograms.chromaticity`)."""
    maps = edge_maps(frame.image, colour=colour_edges)
    return FrameCues(frame.camera.intrinsics, frame.camera.T_cam_base,
                     motion_edge_maps(maps, flow), None if lut is None else
                     lut.posterior(frame.image), quantize(
                         chromaticity(frame.image) if colours == "chromaticity" else frame.image,
                         bins),
                     cv2.countNonZero(maps.edges) / maps.edges.size)
