"""Rerun drawing of the ``kpf`` tracker: per frame the best mode's back-projected limbs (the
cones' boundary lines, the hands' and head's ellipses) and the heaviest mean-shift modes'
right forearms over the image, and the model's skeleton in 3-D beside the avatar; at the end
the wrist-error series."""

from __future__ import annotations

import numpy as np
import rerun as rr

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.scores import errors
from humimic.viz.rerun_log import PIXEL_CENTRE_SHIFT, image_entity

#: Skeleton chains drawn in 3-D.
_CHAINS = (("r_shoulder", "r_elbow", "r_wrist"), ("l_shoulder", "l_elbow", "l_wrist"),
           ("r_shoulder", "spine", "l_shoulder"), ("spine", "neck"))
_MODE_COLOR, _MODES_COLOR = (255, 140, 0), (80, 160, 255)


def _lines_2d(rlog, t: float, entity: str, strips, color) -> None:
    """Image polylines in OpenCV pixels (rerun puts pixel centres at +0.5)."""
    rlog.log(t, entity, rr.LineStrips2D([np.asarray(s, float) + PIXEL_CENTRE_SHIFT for s in strips],
                                        colors=[color]))


def model_strips(body: bm.BodyModel, q: np.ndarray, intrinsics, T_cam_base, parts=None
                 ) -> list[np.ndarray]:
    """Image polylines (pixels) of states ``q (M, 14)``: each cone's two boundary lines and
    each ellipsoid's outline (``parts`` restricts to those part names)."""
    view = bm.project(body, body.forward(q), intrinsics, T_cam_base)
    strips = []
    for i in range(len(q)):
        for j, name in enumerate(view.limb_names):
            if (parts is None or name in parts) and view.valid[i, view.cone_idx[j]]:
                strips += [view.sides_uv[i, j, 0], view.sides_uv[i, j, 1]]
        for k in view.ellipsoid_idx:
            if (parts is None or view.part_names[k] in parts) and view.valid[i, k]:
                o = view.outline.uv[i, k]
                strips.append(np.vstack([o, o[:1]]))
    return [s for s in strips if np.all(np.isfinite(s))]


def log_frame(rlog, name: str, camera: str, t: float, body, frame, T_cam_base, res,
              T_world_base) -> None:
    img = image_entity(camera)
    intr = frame.camera.intrinsics
    _lines_2d(rlog, t, f"{img}/{name}/mode", model_strips(body, res.mode[None], intr,
                                                          T_cam_base), _MODE_COLOR)
    _lines_2d(rlog, t, f"{img}/{name}/modes",
              model_strips(body, res.modes, intr, T_cam_base, ("r_forearm",)), _MODES_COLOR)
    pose = body.forward(res.mode[None]).to(T_world_base)
    rlog.log_lines_3d(t, f"world/estimates/{name}",
                      [np.stack([pose.joint(j)[0] for j in c]) for c in _CHAINS],
                      colors=[_MODE_COLOR], radii=0.01)


def log_run(rlog, name: str, rec, world, body) -> None:
    if rlog is None or not rlog.enabled or not rec.t:
        return
    e = errors(rec, world, body)
    rlog.log_series(f"series/trackers/{name}/wrist_error_mm", np.asarray(rec.t),
                    1e3 * np.column_stack([e["wrist"], e["lateral"], e["depth"]]),
                    names=["wrist", "image plane", "depth"])
