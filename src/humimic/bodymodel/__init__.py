"""Articulated upper-body model and its projection, shared by Menezes et al.'s 3-D trackers
(sec. 6: quadrics and truncated cones, hidden-part removal, contour points for the shape cue)
and Schmidt et al.'s kernel particle filter (sec. 4: elliptic cylinders, one polygon per limb,
edge / ridge / colour sample points). Everything is vectorised over N particles.

State: :data:`DOF_NAMES` (torso x y z yaw pitch roll, then ``SFE SAA HR EB`` per arm in DB's
joint convention, :mod:`humimic.bodymodel.kinematics`); a model frees a subset. Units: m, rad,
pixels. Usage, for the trackers::

    from humimic import bodymodel as bm
    from humimic.sensors.camera_model import invert_transform

    T_cam_base = invert_transform(camera.T_base_cam)     # torso pose in the robot base frame

    # Schmidt (kpf): 14 DOF, elliptic cylinders
    body = bm.avatar_body(torso="cylinder")
    q = body.clamp(bm.truth_state(world, 0, "base") + noise)          # (N, 14) particles
    pose = body.forward(q)                   # joints: pose.joint("r_wrist") (N, 3), base frame
    view = bm.project(body, pose, camera.intrinsics, T_cam_base, n_vertices=8)
    edges = bm.limb_edges(view, 20)          # uv, normal (N, limbs, 20, 2), angle, ok
    ridges = bm.limb_ridges(view, 30)        # uv, width (px), depth (m) along each limb axis
    bands = bm.limb_bands(view, 3, 0.2)      # (N, limbs, 3, 4, 2) colour polygons
    limbs = view.limb_names                  # ("torso", "r_upper_arm", ...)
    skin = view.outline.uv[:, view.index("r_hand")]   # (N, V, 2) polygon of a hand
    # the same limb fields and image ellipses compiled (the kpf likelihood's hot path)
    from humimic.bodymodel.limb_view import limb_view
    lv = limb_view(body, pose, camera.intrinsics, T_cam_base)

    # Menezes (tbp): 8 DOF, torso pose from the face tracker, hidden-part removal
    arms = bm.avatar_body().with_free(bm.ARM_DOFS["R"] + bm.ARM_DOFS["L"])
    view = bm.project(arms, arms.forward(q8, fixed=torso6), camera.intrinsics, T_cam_base)
    pts = bm.contour_points(view, 20)        # uv, normal, visible (N, parts, 20)

    # Menezes (gest): a free hand ellipsoid, 9-D state (one part: add the parts axis)
    R, c, axes = bm.hand_ellipsoids(states)                            # states (N, 9)
    R, c = bm.to_camera(T_cam_base, R, c)
    outline, quadric, conic = bm.project_ellipsoids(R[:, None], c[:, None], axes[:, None],
                                                    camera.intrinsics, 16)
    pts = bm.resample(outline, 20)           # N_p = 20 points and normals (Menezes eq. 2)

Ground truth for the metrics: :func:`truth_state`, :func:`truth_angles`,
:func:`truth_torso_pose`, :func:`truth_hand_state` (:mod:`humimic.bodymodel.avatar`).
Rasterising for tests and display: :func:`label_mask`, :func:`part_masks`.
"""

from humimic.bodymodel.avatar import (
    shoulder_angles,
    state_from_qpos,
    truth_angles,
    truth_hand_state,
    truth_state,
    truth_torso_pose,
)
from humimic.bodymodel.dimensions import avatar_body, avatar_parts, avatar_skeleton, db_skeleton
from humimic.bodymodel.features import (
    ContourPoints,
    contour_points,
    limb_bands,
    limb_edges,
    limb_ridges,
    resample,
)
from humimic.bodymodel.hand import HAND_STATE, hand_ellipsoids, to_camera
from humimic.bodymodel.kinematics import ARM_DOFS, DOF_NAMES, SEGMENTS, TORSO_DOFS, Skeleton
from humimic.bodymodel.limits import DEFAULT_LIMITS, JointLimits, JointLimitsConfig
from humimic.bodymodel.model import BodyModel, Cone, Ellipsoid, Part, Pose, cone_between
from humimic.bodymodel.projection import (
    BodyView,
    Outline,
    project,
    project_cones,
    project_ellipsoids,
)
from humimic.bodymodel.raster import label_mask, part_masks

__all__ = [
    "ARM_DOFS", "DEFAULT_LIMITS", "DOF_NAMES", "HAND_STATE", "SEGMENTS", "TORSO_DOFS",
    "BodyModel", "BodyView", "Cone", "ContourPoints", "Ellipsoid", "JointLimits",
    "JointLimitsConfig", "Outline", "Part", "Pose", "Skeleton",
    "avatar_body", "avatar_parts", "avatar_skeleton", "cone_between", "contour_points",
    "db_skeleton", "hand_ellipsoids", "label_mask", "limb_bands", "limb_edges", "limb_ridges",
    "part_masks", "project", "project_cones", "project_ellipsoids", "resample",
    "shoulder_angles", "state_from_qpos", "to_camera", "truth_angles", "truth_hand_state",
    "truth_state", "truth_torso_pose",
]
