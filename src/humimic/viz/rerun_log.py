"""One run's rerun recording: the scene, body poses, eye images and every stage's output.

:class:`RerunLog` owns one ``rerun.RecordingStream`` (never the global recording). Everything
is logged against the ``sim_time`` timeline (simulated seconds). Entity layout: see
:mod:`humimic.viz.entities`. Here: ``world`` is z-up (static ViewCoordinates); each body's geoms
are static entities ``{body}/{kind}`` in body coordinates (kind: boxes, capsules, ellipsoids,
cylinders, planes, walls or mesh_{geom}; room walls see-through) under ``world/room``,
``world/db`` (robot) and ``world/human``, placed by a Transform3D per :meth:`log_poses`;
``world/base`` is static T_world_base with axes; ``world/cameras/{cam}`` is T_world_cam
(OpenCV axes = rerun RDF) and ``.../image`` a static Pinhole + JPEG, with 2-D overlays below it
in OpenCV pixel coordinates.

Moving bodies are the MuJoCo bodies with a joint (or mocap); jointless children are drawn as
part of their moving ancestor, jointless bodies welded to the world as static entities.

Usage -- always as a context manager, so Ctrl-C still leaves a complete ``.rrd``::

    with RerunLog(scene, "save", out / "run.rrd", recording_id=run_id) as rlog:
        rlog.log_static_scene()        # then rlog.log_poses(t) in the loop; close() on exit

With ``mode="off"`` no stream is created and every method returns at once.
Pixel coordinates passed in are OpenCV's; overlays are shifted by :data:`PIXEL_CENTRE_SHIFT`.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import rerun as rr

from humimic.sensors.camera_model import CameraImage
from humimic.viz.entities import (  # noqa: F401 -- the names every logger uses, re-exported
    AXIS_RGB,
    BASE,
    CAMERAS,
    ESTIMATES,
    EVENTS,
    OTHER_COLOR,
    PIXEL_CENTRE_SHIFT,
    ROOM,
    SERIES,
    TARGET_COLORS,
    TIMELINE,
    TRUTH,
    WORLD,
    Mode,
    body_entity,
    camera_entity,
    image_entity,
)
from humimic.viz.geometry import (
    ellipse_points,
    ellipsoid_axes,
    geom_archetypes,
    label_anchors,
    rigid_root,
    scene_geoms,
)
from humimic.viz.rerun_columns import ColumnLog

#: Payload (bytes, estimated) handed to the SDK between blocking flushes. The SDK encodes and
#: writes on its own threads: unbounded, ten minutes' joint series (30 x 250 000 rows, sent in
#: chunks of :data:`~humimic.viz.rerun_columns.SERIES_CHUNK` rows) queue up faster than written,
#: +279 MiB of peak memory; +32 MiB so.
BACKLOG_BYTES = 8 << 20
#: Wall seconds between the SDK's own flushes when saving. Its default, 0.2 s, cuts a chunk per
#: entity five times a second, and the file sink keeps an index entry per chunk until it closes,
#: then builds its footer from them: 120 000 small chunks held +43 MiB and peaked +59 MiB more at
#: close (measured); a ten-minute run peaked as its recording closed. 5 s: 25x fewer chunks.
FLUSH_TICK_S = 5.0
#: Estimated cost of one small ``log`` call (a few points or a text), on top of its arrays.
_LOG_CALL_BYTES = 512


class RerunLog(ColumnLog):
    """Thin wrapper around one ``RecordingStream``; every method takes simulated time in s.
    Whole-run series and per-row trails (``log_series``, ``log_points_rows``,
    ``log_arrows_rows``) are :class:`~humimic.viz.rerun_columns.ColumnLog`'s.

    ``mode``: ``off`` (no-op), ``save`` (stream to ``path``, no viewer) or ``spawn`` (open a
    viewer; also write ``path`` if given). ``blueprint`` (see :mod:`humimic.viz.blueprint`) is
    stored as the recording's default layout. Poses are buffered and sent in columns every
    ``pose_batch`` calls (default 300 when saving: the file sink keeps an index entry per chunk
    until it closes; 6 when a viewer is live) and on close.
    """

    def __init__(self, scene, mode: Mode, path: Path | None, recording_id: str,
                 app_id: str = "humimic", blueprint=None, pose_batch: int | None = None):
        if mode not in ("off", "save", "spawn"):
            raise ValueError(f"rerun mode must be off, save or spawn, not {mode!r}")
        if mode == "save" and path is None:
            raise ValueError("rerun mode 'save' needs a path for the .rrd")
        self.scene, self.mode, self.path = scene, mode, path
        self._rec: rr.RecordingStream | None = None
        self.logged: set[str] = set()
        """Entities that got series, text or images (what a layout can show)."""
        if mode == "off":
            return
        m = scene.model
        self._moving = np.array([b for b in range(1, m.nbody) if rigid_root(m, b) == b],
                                dtype=np.intp)
        self._moving_paths = [body_entity(m, int(b)) for b in self._moving]
        cap = pose_batch or (300 if mode == "save" else 6)
        self._pose_t = np.empty(cap)
        self._pose_p = np.empty((cap, len(self._moving), 3))
        self._pose_q = np.empty((cap, len(self._moving), 4))
        self._pose_k = 0
        self._backlog = 0
        self._pinholes: dict[str, tuple] = {}
        self._static_done: set[str] = set()

        batcher = (rr.ChunkBatcherConfig(flush_tick=FLUSH_TICK_S, flush_num_bytes=BACKLOG_BYTES)
                   if mode == "save" else None)  # a live viewer keeps the SDK's low latency
        rec = rr.RecordingStream(app_id, recording_id=recording_id, batcher_config=batcher)
        rec.set_log_time_enabled(False)  # sim_time is the only timeline
        if path is not None:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
        if mode == "save":
            rec.save(path, default_blueprint=blueprint)
        else:
            rr.spawn(connect=False)
            sinks = [rr.GrpcSink()] + ([rr.FileSink(path)] if path is not None else [])
            rec.set_sinks(*sinks, default_blueprint=blueprint)
        rec.log(WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._rec = rec

    # ---- lifecycle -----------------------------------------------------------------------------
    @property
    def enabled(self) -> bool:
        return self._rec is not None

    @property
    def pose_entities(self) -> list[str]:
        """Entities of the moving bodies that :meth:`log_poses` places (empty when off)."""
        return list(self._moving_paths) if self.mode != "off" else []

    def __enter__(self) -> RerunLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Send buffered poses, flush and detach the sinks (the .rrd is then complete).

        Idempotent; runs from ``__exit__`` also on KeyboardInterrupt.
        """
        if self._rec is None:
            return
        rec = self._rec
        try:
            self._flush_poses()
        finally:
            self._rec = None
            rec.flush(timeout_sec=30.0)
            rec.disconnect()

    def send_blueprint(self, blueprint) -> None:
        """Make ``blueprint`` the active and default layout (when it is known only later)."""
        if self._rec is not None:
            self._rec.send_blueprint(blueprint, make_active=True, make_default=True)

    def _sent(self, nbytes: int) -> None:
        """Count ``nbytes`` handed to the SDK; past :data:`BACKLOG_BYTES`, wait until the SDK
        has written what it holds (memory stays bounded however much a run logs)."""
        self._backlog += int(nbytes) + _LOG_CALL_BYTES
        if self._backlog >= BACKLOG_BYTES and self._rec is not None:
            self._rec.flush(timeout_sec=60.0)
            self._backlog = 0

    # ---- scene -------------------------------------------------------------------------------
    def log_static_scene(self, groups: tuple[int, ...] = (0, 1, 2)) -> None:
        """Log every geom of the compiled model once (static), grouped per body entity.

        Geoms in MuJoCo groups not in ``groups`` are skipped (group 3 holds the Wii remote).
        Static bodies get a static world pose, moving ones are placed by :meth:`log_poses`.
        Also logs ``world/base`` (static T_world_base with 0.15 m axes).
        """
        if self._rec is None:
            return
        rec, m = self._rec, self.scene.model
        per_entity, static_bodies = scene_geoms(m, groups)
        for entity, T_world_body in static_bodies.items():
            if entity not in self._static_done:
                self._static_done.add(entity)
                rec.log(entity, rr.Transform3D(translation=T_world_body[:3, 3],
                                               mat3x3=T_world_body[:3, :3]), static=True)
        for entity, geoms in per_entity.items():
            for kind, archetype in geom_archetypes(m, geoms, static=entity.startswith(ROOM)):
                rec.log(f"{entity}/{kind}", archetype, static=True)
        self.log_transform(0.0, BASE, self.scene.T_world_base, static=True, axis_length_m=0.15)

    def log_poses(self, t: float) -> None:
        """Buffer every moving body's world pose (``data.xpos``/``xquat``) at time ``t``.

        Sent as one ``Transform3D`` column per body every ``pose_batch`` calls and on close.
        """
        if self._rec is None:
            return
        k, d, idx = self._pose_k, self.scene.data, self._moving
        self._pose_t[k] = t
        self._pose_p[k] = d.xpos[idx]
        q_wxyz = d.xquat[idx]
        self._pose_q[k, :, :3] = q_wxyz[:, 1:]
        self._pose_q[k, :, 3] = q_wxyz[:, 0]
        self._pose_k = k + 1
        if self._pose_k == len(self._pose_t):
            self._flush_poses()

    def _flush_poses(self) -> None:
        k = self._pose_k
        if self._rec is None or k == 0:
            return
        times = [rr.TimeColumn(TIMELINE, duration=self._pose_t[:k].copy())]
        for i, path in enumerate(self._moving_paths):
            self._rec.send_columns(path, indexes=times, columns=rr.Transform3D.columns(
                translation=self._pose_p[:k, i], quaternion=self._pose_q[:k, i]))
        self._pose_k = 0
        self._sent(self._pose_t[:k].nbytes * (1 + 7 * len(self._moving_paths)))

    def log_transform(self, t: float, entity: str, T_parent_child: np.ndarray,
                      static: bool = False, axis_length_m: float | None = None) -> None:
        """A 4x4 pose of ``entity`` in its parent entity's frame (optionally with axes)."""
        if self._rec is None:
            return
        T = np.asarray(T_parent_child, dtype=float)
        parts = [rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3])]
        if axis_length_m is not None:
            parts.append(rr.TransformAxes3D(axis_length_m))
        if not static:
            self._rec.set_time(TIMELINE, duration=t)
        self._rec.log(entity, *parts, static=static)
        self._sent(0)

    # ---- cameras -----------------------------------------------------------------------------
    def log_camera_image(self, t: float, entity: str, cam_image: CameraImage,
                         jpeg_quality: int | None = 80, static_pose: bool = False,
                         image_plane_distance_m: float = 0.2) -> None:
        """Camera pose at ``entity`` (T_world_cam), pinhole + image at ``entity/image``.

        The image shows in a 2-D view of ``entity/image`` and, in 3-D, on the camera's frustum
        drawn ``image_plane_distance_m`` in front of it. ``jpeg_quality=None`` logs raw pixels.
        ``static_pose`` logs the pose once, as static (a camera that does not move).
        The pinhole has no distortion; a distorted image is shown as rendered.
        """
        if self._rec is None:
            return
        rec, cam = self._rec, cam_image.camera
        rec.set_time(TIMELINE, duration=t)
        T = cam.T_world_cam
        if not static_pose or entity not in self._static_done:
            rec.log(entity, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                    static=static_pose)
            if static_pose:
                self._static_done.add(entity)
        img = f"{entity}/image"
        self.logged.add(img)
        K = cam.intrinsics.K.copy()
        K[:2, 2] += PIXEL_CENTRE_SHIFT
        h, w = cam_image.image.shape[:2]
        key = (K.tobytes(), w, h, image_plane_distance_m)
        if self._pinholes.get(img) != key:
            self._pinholes[img] = key
            rec.log(img, rr.Pinhole(image_from_camera=K, resolution=[w, h],
                                    camera_xyz=rr.ViewCoordinates.RDF,
                                    image_plane_distance=image_plane_distance_m), static=True)
        if jpeg_quality is None:
            rec.log(img, rr.Image(cam_image.image))
        else:  # OpenCV's encoder is ~3x faster than rr.Image.compress at 320x240
            bgr = cv2.cvtColor(cam_image.image, cv2.COLOR_RGB2BGR)
            ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
            if not ok:
                raise RuntimeError(f"JPEG encoding of {img} failed")
            rec.log(img, rr.EncodedImage(contents=buf.tobytes(), media_type="image/jpeg"))
        self._sent(cam_image.image.nbytes if jpeg_quality is None else len(buf))

    def log_ellipses_2d(self, t: float, entity: str, centers_px: np.ndarray,
                        covariances_px2: np.ndarray, n_sigma: float = 2.0, colors=None,
                        labels=None, n_points: int = 48) -> None:
        """Blobs as ``n_sigma`` ellipses (LineStrips2D) plus centre points on a camera image,
        their ``labels`` at ``entity/labels``, placed above the ellipses where they do not
        overlap (:func:`~humimic.viz.geometry.label_anchors`: targets close together get
        stacked names, never ``right_hanhead``).

        ``entity`` lies below an image entity (``image_entity("L_wide") + "/blobs"``);
        centres (N, 2) and covariances (N, 2, 2) in OpenCV pixels.
        """
        if self._rec is None:
            return
        c = np.asarray(centers_px, dtype=float).reshape(-1, 2) + PIXEL_CENTRE_SHIFT
        cov = np.asarray(covariances_px2, dtype=float).reshape(-1, 2, 2)
        strips = ellipse_points(c, cov, n_sigma, n_points)
        self._rec.set_time(TIMELINE, duration=t)
        self._rec.log(entity, rr.LineStrips2D(strips, colors=colors),
                      rr.Points2D(c, colors=colors, radii=1.5))
        if labels is not None:
            self._rec.log(f"{entity}/labels", rr.Points2D(
                label_anchors(c, cov, n_sigma, list(labels)), colors=colors, radii=0.01,
                labels=list(labels), show_labels=True))
        self._sent(strips.nbytes)

    # ---- 3-D ---------------------------------------------------------------------------------
    def log_points(self, t: float, entity: str, points: np.ndarray, colors=None,
                   radii=0.012, labels=None, show_labels: bool = False) -> None:
        """Points (N, 3) in the frame of ``entity``'s parent (world under ``world/truth``).
        Labels show on hover unless ``show_labels``."""
        if self._rec is None:
            return
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        self._rec.set_time(TIMELINE, duration=t)
        self._rec.log(entity, rr.Points3D(points, colors=colors, radii=radii, labels=labels,
                                          show_labels=show_labels))
        self._sent(points.nbytes + 16 * len(labels or ()))

    def log_ellipsoids_3d(self, t: float, entity: str, centers: np.ndarray,
                          covariances: np.ndarray, n_sigma: float = 2.0, colors=None,
                          labels=None, point_radius: float = 0.018) -> None:
        """Covariance ellipsoids (wireframe; labels on hover) and their centres as points of
        radius ``point_radius`` (a 2-sigma ellipsoid of a few mm is invisible at room scale):
        centres (N, 3) in m, covariances (N, 3, 3) in m^2."""
        if self._rec is None:
            return
        half_sizes, q_xyzw = ellipsoid_axes(
            np.asarray(covariances, dtype=float).reshape(-1, 3, 3), n_sigma)
        centers = np.asarray(centers, dtype=float).reshape(-1, 3)
        self._rec.set_time(TIMELINE, duration=t)
        self._rec.log(entity, rr.Ellipsoids3D(
            centers=centers, half_sizes=half_sizes, quaternions=q_xyzw, colors=colors,
            labels=labels, show_labels=False,
            fill_mode=rr.components.FillMode.MajorWireframe),
            rr.Points3D(centers, colors=colors, radii=point_radius, labels=labels,
                        show_labels=False))
        self._sent(centers.nbytes * 4)

    def log_arrow(self, t: float, entity: str, origin: np.ndarray, vector: np.ndarray,
                  colors=None, labels=None) -> None:
        """Arrow(s) from ``origin`` along ``vector`` (m), e.g. the gaze direction."""
        if self._rec is None:
            return
        self._rec.set_time(TIMELINE, duration=t)
        self._rec.log(entity, rr.Arrows3D(
            origins=np.asarray(origin, dtype=float).reshape(-1, 3),
            vectors=np.asarray(vector, dtype=float).reshape(-1, 3), colors=colors, labels=labels))
        self._sent(0)

    def log_lines_3d(self, t: float, entity: str, strips, colors=None, radii=0.003,
                     labels=None) -> None:
        """Polylines (list of (M, 3) arrays), e.g. commanded-to-reached error segments."""
        if self._rec is None:
            return
        self._rec.set_time(TIMELINE, duration=t)
        self._rec.log(entity, rr.LineStrips3D(strips, colors=colors, radii=radii, labels=labels))
        self._sent(sum(np.asarray(s).nbytes for s in strips))

    # ---- series and events --------------------------------------------------------------------
    def log_scalar(self, t: float, entity: str, value) -> None:
        """One sample (a float, or a 1-D array for several lines in one plot) at ``t``."""
        if self._rec is None:
            return
        self.logged.add(entity)
        self._rec.set_time(TIMELINE, duration=t)
        self._rec.log(entity, rr.Scalars(np.atleast_1d(np.asarray(value, dtype=float))))
        self._sent(0)

    def log_text(self, t: float, entity: str, text: str, level: str = "INFO") -> None:
        """A text event (``INFO``, ``WARN``, ``ERROR`` ...), e.g. ``searching -> tracking``."""
        if self._rec is None:
            return
        self.logged.add(entity)
        self._rec.set_time(TIMELINE, duration=t)
        self._rec.log(entity, rr.TextLog(text, level=level))
        self._sent(len(text))

    def log(self, t: float, entity: str, *archetypes) -> None:
        """Any rerun archetypes at ``t`` (overlays the methods above do not cover)."""
        if self._rec is not None:
            self._rec.set_time(TIMELINE, duration=t)
            self._rec.log(entity, *archetypes)
            self._sent(0)
