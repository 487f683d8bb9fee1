"""What the wearable sensors were given to work with, scored from ground truth (``wearable.*``).

Any scenario with the head camera on gets, in ``metrics.json``:

* ``corners_per_frame_min`` / ``_p05`` / ``_mean``: trackable corners in the head camera's
  frames (:func:`count_corners`: OpenCV ``goodFeaturesToTrack``, :data:`CORNER_PARAMS`) -- the
  room's texture as a feature tracker sees it along the path;
* ``marker_in_view_fraction``: frames in which the Wii remote's red marker centre projects
  inside the image, in front of the camera (ground truth; occlusion not considered);
* ``head_path_horizontal_m`` (the path over the floor, in the paper's W: a jump adds nothing),
  ``head_speed_max_m_s`` (3-D), ``head_yaw_range_deg``: how the interface (frame I) moved;
* ``imu_orientation_error_rms_deg``: the head IMU's orientation error (yaw, pitch, roll, the
  Euler angles of :data:`humimic.sensors.inertial.EULER`).
"""

from __future__ import annotations

import cv2
import numpy as np

from humimic.pipeline.stage import Stage
from humimic.world.frames import R_CV_I

#: ``cv2.goodFeaturesToTrack`` parameters of :func:`count_corners` (Shi-Tomasi corners at least
#: 1 % of the strongest's quality, 8 px apart).
CORNER_PARAMS = {"maxCorners": 500, "qualityLevel": 0.01, "minDistance": 8, "blockSize": 3}


def count_corners(image: np.ndarray) -> int:
    """Shi-Tomasi corners in an RGB ``image`` with :data:`CORNER_PARAMS`."""
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
    corners = cv2.goodFeaturesToTrack(grey, **CORNER_PARAMS)
    return 0 if corners is None else len(corners)


class WearableProbe(Stage):
    """Counts corners in every head-camera frame; scores the rest from ground truth."""

    name = "wearable_probe"

    def __init__(self, world):
        self.world = world
        self.t: list[float] = []
        self.corners: list[int] = []

    def attach(self, bus, timer) -> None:
        self.timer = timer
        bus.subscribe("headcam", self._on_frame)

    def _on_frame(self, topic, msg) -> None:
        with self.timer.time(self.name):
            self.t.append(msg.t)
            self.corners.append(count_corners(msg.value.image))

    def metrics(self) -> dict:
        if not self.t:
            return {}
        gt, w = self.world.gt, self.world
        k = gt.index_of(np.array(self.t))
        corners = np.array(self.corners)
        p_W = gt.position("headcam", "W")[k]
        intr = w.head_rig.intrinsics("headcam")
        T = gt.pose("headcam")[k]
        rel = gt.p_world("wiimote_marker")[k] - T[:, :3, 3]
        p_I = np.einsum("nji,nj->ni", T[:, :3, :3], rel)
        p_cv = p_I @ R_CV_I.T
        uv = intr.project(p_cv)
        inside = ((p_cv[:, 2] > 0.05) & (uv[:, 0] >= 0) & (uv[:, 0] <= intr.width - 1)
                  & (uv[:, 1] >= 0) & (uv[:, 1] <= intr.height - 1))
        xz = p_W[:, [0, 2]]
        z_axis = gt.rotation("headcam", "W")[k][:, :, 2]
        yaw = np.degrees(np.unwrap(np.arctan2(z_axis[:, 0], z_axis[:, 2])))
        out = {
            "headcam_frames": len(self.t),
            "corners_per_frame_min": int(corners.min()),
            "corners_per_frame_p05": float(np.percentile(corners, 5)),
            "corners_per_frame_mean": float(corners.mean()),
            "marker_in_view_fraction": float(inside.mean()),
            "head_path_horizontal_m": float(np.sum(np.linalg.norm(np.diff(xz, axis=0), axis=1))),
            "head_speed_max_m_s": float(np.max(np.linalg.norm(gt.v_world("headcam"), axis=1))),
            "head_yaw_range_deg": float(np.ptp(yaw)),
        }
        if w.imu is not None and w.imu[0].orientation is not None:
            err = np.degrees(w.imu[0].orientation.errors)
            out["imu_orientation_error_rms_deg"] = dict(zip(
                ("yaw", "pitch", "roll"), np.sqrt(np.mean(err**2, axis=0)).tolist(),
                strict=True))
        return {"wearable": out}
