"""humimic.viz: the .rrd a run writes, read back with rerun's own reader; mode off; PNG plots.

The recording is checked independently of the code that wrote it: poses against MuJoCo's
``xpos``/``xquat``, the static geometry (placed by the logged pose) against MuJoCo's
``geom_xpos``, the camera against the rig's ``T_world_cam``/``K``, and the JPEG decoded.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pyarrow as pa
import pytest
from PIL import Image
from rerun.chunk import RrdReader
from scipy.spatial.transform import Rotation

from humimic.sensors.cameras import CameraRig, CameraSpec
from humimic.viz import RerunLog, camera_entity, default_blueprint, image_entity
from humimic.viz.plots import plot_error_budget, plot_errors, plot_trajectories
from humimic.viz.rerun_log import ellipse_points, ellipsoid_axes
from humimic.world.scene import build_scene

DT_FRAME = 1.0 / 30.0
N_FRAMES = 6
T_IMAGE = 2 * DT_FRAME


@pytest.fixture(scope="module")
def scene():
    return build_scene()


@pytest.fixture(scope="module")
def recorded(scene, tmp_path_factory):
    """A tiny run: static scene, 6 pose samples at 30 Hz, one L_wide frame and overlays."""
    import mujoco  # after humimic (imported above) picked the headless GL backend

    m, d = scene.model, scene.data
    path = tmp_path_factory.mktemp("rrd") / "run.rrd"
    rig = CameraRig(scene, [CameraSpec("L_wide", 320, 240)], np.random.default_rng(0))
    blueprint = default_blueprint([camera_entity("L_wide")], [("series", "series")])
    truth: dict[float, dict[str, np.ndarray]] = {}
    shoulder = m.jnt_qposadr[m.joint("human/r_shoulder").id]
    with RerunLog(scene, "save", path, recording_id="test-run", blueprint=blueprint) as rlog:
        rlog.log_static_scene()
        for k in range(N_FRAMES):
            t = k * DT_FRAME
            angle = 0.3 * k  # swing the right arm so poses differ between samples
            d.qpos[shoulder:shoulder + 4] = [np.cos(angle / 2), np.sin(angle / 2), 0.0, 0.0]
            mujoco.mj_forward(m, d)
            rlog.log_poses(t)
            truth[t] = {"xpos": d.xpos.copy(), "xquat": d.xquat.copy(),
                        "geom_xpos": d.geom_xpos.copy()}
            if t == T_IMAGE:
                cam_image = rig.capture(t)["L_wide"]
                rlog.log_camera_image(t, camera_entity("L_wide"), cam_image, jpeg_quality=90)
                rlog.log_ellipses_2d(t, image_entity("L_wide") + "/blobs", [[160.0, 120.0]],
                                     [np.diag([100.0, 25.0])], labels=["head"])
        rlog.log_points(T_IMAGE, "world/truth/head", [[1.3, 0.0, 1.6]], labels=["head"])
        rlog.log_ellipsoids_3d(T_IMAGE, "world/estimates/head", [[1.3, 0.0, 1.6]],
                               [np.diag([1e-4, 4e-4, 9e-4])])
        rlog.log_arrow(T_IMAGE, "world/gaze", [0.0, 0.0, 1.6], [1.0, 0.0, 0.0])
        rlog.log_scalar(T_IMAGE, "series/error", 0.01)
        rlog.log_series("series/truth", np.arange(11) * 0.1, np.ones((11, 3)), names=list("xyz"))
        rlog.log_text(T_IMAGE, "events/tracker", "searching -> tracking")
        pose_entities = rlog.pose_entities
    rig.close()
    return {"path": path, "truth": truth, "cam_image": cam_image, "pose_entities": pose_entities,
            "chunks": read_rrd(path)}


def read_rrd(path: Path) -> dict[str, list[tuple[bool, pa.RecordBatch]]]:
    out = defaultdict(list)
    for chunk in RrdReader(path).stream():
        out[chunk.entity_path].append((chunk.is_static, chunk.to_record_batch()))
    return out


def column(chunks, entity: str, component: str, static: bool = False):
    """(times in ns or None, values) of ``component`` over every chunk of ``entity``."""
    times, values = [], []
    for is_static, rb in chunks["/" + entity]:
        if is_static != static or component not in rb.schema.names:
            continue
        values += rb.column(component).to_pylist()
        if not static:
            times += list(rb.column("sim_time").cast(pa.int64()).to_numpy())
    assert values, f"{component} not logged at {entity}"
    return (None if static else np.array(times)), values


def row_at(times_ns: np.ndarray, t: float) -> int:
    """Index of the row logged at ``t`` s (rerun stores whole nanoseconds)."""
    return int(np.flatnonzero(np.abs(times_ns - t * 1e9) < 1.5)[0])


def test_rrd_has_the_expected_entities(recorded, scene):
    chunks = recorded["chunks"]
    reader = RrdReader(recorded["path"])
    rec = reader.recordings()[0]
    assert (rec.application_id, rec.recording_id) == ("humimic", "test-run")
    assert reader.blueprints(), "the default blueprint is stored in the file"
    for entity in ["world", "world/room/planes", "world/room/walls", "world/room/screen/boxes",
                   "world/base", "world/db/pelvis/boxes", "world/db/torso/capsules",
                   "world/human/head/ellipsoids", "world/human/r_forearm/capsules",
                   "world/cameras/L_wide", "world/cameras/L_wide/image",
                   "world/cameras/L_wide/image/blobs", "world/truth/head",
                   "world/estimates/head", "world/gaze", "series/error", "series/truth",
                   "events/tracker"]:
        assert "/" + entity in chunks, entity
    assert "/world/human/wiimote" not in chunks  # geom group 3 is hidden by default
    n_moving = sum(1 for b in range(1, scene.model.nbody) if scene.model.body_jntnum[b] > 0)
    assert len(recorded["pose_entities"]) == n_moving
    for entity in recorded["pose_entities"]:
        times, _ = column(chunks, entity, "Transform3D:translation")
        assert len(times) == N_FRAMES
    # Geometry is static, poses are not.
    assert all(s for s, _ in chunks["/world/db/torso/capsules"])
    _, _ = column(chunks, "world/db/torso", "Transform3D:quaternion")


@pytest.mark.parametrize("body", ["human/r_hand", "human/r_forearm", "db/R_forearm"])
def test_pose_at_a_given_time_matches_mujoco(recorded, scene, body):
    t = 4 * DT_FRAME
    times, p = column(recorded["chunks"], f"world/{body}", "Transform3D:translation")
    _, q = column(recorded["chunks"], f"world/{body}", "Transform3D:quaternion")
    i = row_at(times, t)
    b = scene.model.body(body).id
    np.testing.assert_allclose(p[i][0], recorded["truth"][t]["xpos"][b], atol=1e-6)
    q_xyzw = np.array(q[i][0])
    w, x, y, z = recorded["truth"][t]["xquat"][b]
    assert abs(np.dot(q_xyzw, [x, y, z, w])) == pytest.approx(1.0, abs=1e-6)


def test_logged_geometry_lands_on_mujoco_geoms(recorded, scene):
    """Capsule centre = logged body pose x logged capsule start + half its length along z."""
    chunks, m = recorded["chunks"], scene.model
    t = (N_FRAMES - 1) * DT_FRAME
    for entity in ("world/human/r_forearm", "world/db/L_upper_arm", "world/human/l_shank"):
        times, p = column(chunks, entity, "Transform3D:translation")
        _, q = column(chunks, entity, "Transform3D:quaternion")
        i = row_at(times, t)
        R_world_body = Rotation.from_quat(q[i][0]).as_matrix()
        _, start = column(chunks, entity + "/capsules", "Capsules3D:translations", static=True)
        _, q_cap = column(chunks, entity + "/capsules", "Capsules3D:quaternions", static=True)
        _, length = column(chunks, entity + "/capsules", "Capsules3D:lengths", static=True)
        _, names = column(chunks, entity + "/capsules", "Capsules3D:labels", static=True)
        for j, name in enumerate(names[0]):
            R_body_cap = Rotation.from_quat(q_cap[0][j]).as_matrix()
            centre_body = np.array(start[0][j]) + R_body_cap[:, 2] * length[0][j] / 2
            centre_world = R_world_body @ centre_body + np.array(p[i][0])
            g = m.geom(name).id
            np.testing.assert_allclose(centre_world, recorded["truth"][t]["geom_xpos"][g],
                                       atol=1e-5)


def test_camera_pose_pinhole_and_image(recorded):
    chunks, cam_image = recorded["chunks"], recorded["cam_image"]
    cam = cam_image.camera
    _, translation = column(chunks, "world/cameras/L_wide", "Transform3D:translation")
    _, mat = column(chunks, "world/cameras/L_wide", "Transform3D:mat3x3")
    np.testing.assert_allclose(translation[0][0], cam.T_world_cam[:3, 3], atol=1e-6)
    np.testing.assert_allclose(np.reshape(mat[0][0], (3, 3)).T, cam.T_world_cam[:3, :3],
                               atol=1e-6)  # rerun stores 3x3 matrices column-major
    _, K = column(chunks, "world/cameras/L_wide/image", "Pinhole:image_from_camera", static=True)
    K_expected = cam.intrinsics.K + np.array([[0, 0, 0.5], [0, 0, 0.5], [0, 0, 0]])
    np.testing.assert_allclose(np.reshape(K[0][0], (3, 3)).T, K_expected, atol=1e-4)
    times, blob = column(chunks, "world/cameras/L_wide/image", "EncodedImage:blob")
    assert len(times) == 1 and row_at(times, T_IMAGE) == 0
    bgr = cv2.imdecode(np.array(blob[0][0], dtype=np.uint8), cv2.IMREAD_COLOR)
    rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    assert rgb.shape == (240, 320, 3)
    assert np.abs(rgb.astype(float) - cam_image.image).mean() < 3.0  # JPEG: measured 1.25
    # The blob ellipse (OpenCV pixels) is drawn half a pixel down-right in rerun's image space.
    _, strips = column(chunks, "world/cameras/L_wide/image/blobs", "LineStrips2D:strips")
    outline = np.array(strips[0][0])
    np.testing.assert_allclose(outline[:-1].mean(axis=0), [160.5, 120.5], atol=1e-6)
    np.testing.assert_allclose(np.ptp(outline, axis=0), [40.0, 20.0], atol=1e-6)  # measured 0


def test_series_are_written_in_bulk(recorded):
    times, values = column(recorded["chunks"], "series/truth", "Scalars:scalars")
    assert len(times) == 11 and np.array(values).shape == (11, 3)
    _, names = column(recorded["chunks"], "series/truth", "SeriesLines:names", static=True)
    assert names[0] == ["x", "y", "z"]


def test_close_after_keyboard_interrupt_leaves_a_complete_rrd(scene, tmp_path):
    path = tmp_path / "interrupted.rrd"
    with pytest.raises(KeyboardInterrupt), RerunLog(scene, "save", path, "ctrl-c") as rlog:
        rlog.log_static_scene()
        rlog.log_poses(0.5)  # still in the pose buffer when the interrupt arrives
        raise KeyboardInterrupt
    assert len(RrdReader(path).store()) > 0  # the footer/manifest was written
    times, _ = column(read_rrd(path), "world/human/head", "Transform3D:translation")
    assert times.tolist() == [500_000_000]


def test_mode_off_writes_nothing(scene, tmp_path):
    path = tmp_path / "off.rrd"
    with RerunLog(scene, "off", path, recording_id="off") as rlog:
        assert not rlog.enabled and rlog.pose_entities == []
        rlog.log_static_scene()
        rlog.log_poses(0.0)
        rlog.log_points(0.0, "world/truth/x", np.zeros((1, 3)))
        rlog.log_ellipses_2d(0.0, "world/cameras/L_wide/image/b", np.zeros((1, 2)),
                             np.eye(2)[None])
        rlog.log_ellipsoids_3d(0.0, "world/estimates/x", np.zeros((1, 3)), np.eye(3)[None])
        rlog.log_scalar(0.0, "series/x", 1.0)
        rlog.log_series("series/y", np.zeros(2), np.zeros(2))
        rlog.log_text(0.0, "events/x", "hello")
        rlog.log_arrow(0.0, "world/gaze", np.zeros(3), np.ones(3))
    assert list(tmp_path.iterdir()) == []


def test_bad_mode_and_missing_path_are_refused(scene):
    with pytest.raises(ValueError, match="off, save or spawn"):
        RerunLog(scene, "record", None, "x")
    with pytest.raises(ValueError, match="needs a path"):
        RerunLog(scene, "save", None, "x")


def test_ellipsoid_axes_reproduce_the_covariance():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(5, 3, 3))
    cov = A @ A.transpose(0, 2, 1) + 1e-3 * np.eye(3)
    half, q_xyzw = ellipsoid_axes(cov, n_sigma=2.0)
    R = Rotation.from_quat(q_xyzw).as_matrix()
    np.testing.assert_allclose(R @ (half[:, :, None] ** 2 * np.eye(3)) @ R.transpose(0, 2, 1),
                               4.0 * cov, rtol=1e-9, atol=1e-12)


def test_ellipse_points_lie_on_the_n_sigma_contour():
    cov = np.array([[[9.0, 2.0], [2.0, 4.0]], [[1.0, 0.0], [0.0, 16.0]]])
    c = np.array([[10.0, 20.0], [-5.0, 3.0]])
    pts = ellipse_points(c, cov, n_sigma=2.0, n_points=32)
    assert pts.shape == (2, 33, 2)
    r = pts - c[:, None]
    mahalanobis2 = np.einsum("npi,nij,npj->np", r, np.linalg.inv(cov), r)
    np.testing.assert_allclose(mahalanobis2, 4.0, rtol=1e-9)
    np.testing.assert_allclose(pts[:, 0], pts[:, -1])  # closed


def _png_stats(path: Path) -> tuple[tuple[int, int], int, float]:
    img = np.asarray(Image.open(path).convert("RGB"))
    ink = float((img.min(axis=2) < 200).mean())
    return (img.shape[1], img.shape[0]), len(np.unique(img.reshape(-1, 3), axis=0)), ink


def test_plots_write_readable_pngs(tmp_path):
    t = np.linspace(0.0, 4.0, 200)
    truth = np.stack([np.sin(t), np.cos(t), 0.1 * t], axis=1)
    t_est = t[::4]
    est = truth[::4] + 0.01
    p1 = plot_trajectories(tmp_path / "a" / "traj.png", t,
                           {"head (true)": truth, "head (filtered)": (t_est, est)},
                           title="Head, robot base frame")
    p2 = plot_errors(tmp_path / "err.png", t, {"x": 0.01 * np.sin(5 * t)},
                     band={"x": np.full_like(t, 0.006)}, title="Filter error", ylabel="m")
    p3 = plot_error_budget(tmp_path / "budget.png", ["R_palm", "L_palm"],
                           {"estimate": [5.0, 6.0], "latency": [16.0, 15.0], "servo": [2.0, 1.0]},
                           {"estimate": [0.1, 0.2], "latency": [0.95, 0.9], "servo": [-0.05, -0.1]},
                           [15.0, 14.0])
    for path, size in ((p1, (880, 715)), (p2, (880, 440)), (p3, (1100, 682))):
        got_size, n_colours, ink = _png_stats(path)
        assert got_size == size, path.name
        assert n_colours > 50 and 0.02 < ink < 0.6, path.name


def test_blob_labels_never_overlap_and_sit_above_their_ellipses():
    """Two targets side by side in the image (a hand before the face): their names are
    stacked, not drawn over each other ('right_hanhead')."""
    from humimic.viz.geometry import label_anchors

    names = ["right_hand", "head", "left_hand"]
    c = np.array([[100.0, 80.0], [104.0, 78.0], [300.0, 40.0]])
    cov = np.array([np.diag([25.0, 36.0]), np.diag([49.0, 64.0]), np.diag([4.0, 4.0])])
    pos = label_anchors(c, cov, 2.0, names, char_px=7.0, line_px=12.0)
    for i in range(3):
        assert pos[i, 1] < c[i, 1] - 2.0 * np.sqrt(cov[i, 1, 1])  # above its ellipse
        for j in range(i):
            overlap_x = abs(pos[i, 0] - pos[j, 0]) < 3.5 * (len(names[i]) + len(names[j]))
            overlap_y = abs(pos[i, 1] - pos[j, 1]) < 12.0
            assert not (overlap_x and overlap_y), (names[i], names[j])
    assert pos[2, 1] == pytest.approx(40.0 - 4.0 - 3.0 - 6.0)  # alone: right above its blob


def layout_views(path: Path) -> list[tuple[str, str]]:
    """``(view class, origin)`` of every view in the ``.rrd``'s stored layout."""
    reader = RrdReader(path)
    views = []
    for store in reader.blueprints():
        for chunk in reader.store(store=store).stream():
            rb = chunk.to_record_batch()
            if "ViewBlueprint:space_origin" in rb.schema.names:
                views += zip((c[0] for c in rb.column("ViewBlueprint:class_identifier")
                              .to_pylist()),
                             (o[0] for o in rb.column("ViewBlueprint:space_origin").to_pylist()),
                             strict=True)
    return views


@pytest.mark.slow
def test_every_view_of_a_runs_layout_has_data(tmp_path):
    """The layout stored with a closed-loop run: every view's origin holds logged data (the
    mimicry panel once pointed at series/mimicry while the data was under series/mimic)."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    scenario = load_scenario(SCENARIOS_DIR / "mimic_tracked_wave.yaml", ["output.plots=false"],
                             duration=1.2)
    run_one(scenario, tmp_path, rerun="save", progress=False)
    views = layout_views(tmp_path / "run.rrd")
    data = {e.lstrip("/") for e, chunks in read_rrd(tmp_path / "run.rrd").items()
            if any(not static for static, _ in chunks)}
    kinds = {}
    for kind, origin in views:
        kinds.setdefault(kind, []).append(origin)
        assert any(e == origin or e.startswith(origin + "/") for e in data), (kind, origin)
    assert sorted(kinds["TimeSeries"]) == ["series/mimicry/R_palm/error_mm",
                                           "series/tracking/head", "series/tracking/right_hand"]
    assert len(kinds["2D"]) == 2 and kinds["3D"] == ["world"] and kinds["TextLog"] == ["events"]
