"""How the still head's stereo disparity error moves when the robot's eyes tilt by a fraction of
a milliradian (as its head nods while its arm waves): noise-free renders of the whole scene,
each eye's head blob from the colour posterior (its moments within 1.3 of the head's largest
semi-axis, projected, of the head's projection),
matched by :class:`~humimic.perception.blobs.stereo.StereoRig` with the colour mask as the stage
matches; per tilt the head's image row and the disparity error (px) of the blob centroids and
of the stereo match against the projections of the head's centre.

``python benchmarks/raster_tilt.py [--step MRAD] [--range MRAD] [--supersample N] [KEY=VALUE ...]``
(``mimic_tracked_wave``'s person at tick 0, scenario overrides as ``--set`` takes them, e.g.
``human.distance=2.2``). Notes: ``docs/ude_perception_notes.md``, "The still head's depth
follows the robot's nod".
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from humimic.perception.blobs.build import check_perception, load_luts  # noqa: E402
from humimic.perception.blobs.stereo import StereoParams, StereoRig  # noqa: E402
from humimic.rngs import Rngs  # noqa: E402
from humimic.scenario.load import load_scenario  # noqa: E402
from humimic.sensors.camera_model import invert_transform  # noqa: E402
from humimic.world.names import ROBOT_JOINTS  # noqa: E402
from humimic.world.world import World  # noqa: E402

SCENARIO = "scenarios/mimic_tracked_wave.yaml"
BLOB_RADIUS_SCALE = 1.3
MATCH_STD_PX = 0.04


def _blob(posterior: np.ndarray, uv: np.ndarray, radius_px: float
          ) -> tuple[np.ndarray, np.ndarray]:
    """Posterior-weighted centre and covariance (px) of the pixels within ``radius_px`` of
    ``uv``."""
    h, w = posterior.shape
    vv, uu = np.mgrid[0:h, 0:w]
    wgt = np.where(np.hypot(uu - uv[0], vv - uv[1]) < radius_px, posterior, 0.0)
    centre = np.array([(wgt * uu).sum(), (wgt * vv).sum()]) / wgt.sum()
    d = np.stack([uu - centre[0], vv - centre[1]], -1)
    return centre, np.einsum("hw,hwi,hwj->ij", wgt, d, d) / wgt.sum()


def _area_render(rig, cam: str, supersample: int) -> np.ndarray:
    """The camera's noise-free image; with ``supersample`` n > 1 rendered at n x n times the
    pixels and averaged over each pixel's n x n samples (an area-integrating camera)."""
    if supersample <= 1:
        return rig.render_ideal(cam)
    hi = rig.render_ideal(cam, scale=supersample).astype(float)
    h, w = hi.shape[0] // supersample, hi.shape[1] // supersample
    return hi.reshape(h, supersample, w, supersample, 3).mean((1, 3)).round().astype(np.uint8)


def tilt_sweep(overrides: list[str], tilts_mrad: np.ndarray, supersample: int = 1
               ) -> list[tuple[float, ...]]:
    """Per tilt: (tilt mrad, head row px, centroid disparity error px, stereo disparity
    error px, ZNCC)."""
    sc = load_scenario(SCENARIO, ["cameras.noise_std=0", *overrides])
    w = World(sc, Rngs(sc.seed))
    m, d, s = w.scene.model, w.scene.data, w.scene
    w.set_robot_pose()
    cams = check_perception(sc, w)
    lut = load_luts(sc, w, cams)["head"]
    joints = [s.robot_qpos[ROBOT_JOINTS.index(j)] for j in ("L_ET", "R_ET")]
    q0 = d.qpos[joints].copy()
    gid = m.geom("human/head").id
    rows = []
    for tilt in tilts_mrad:
        d.qpos[joints] = q0 + 1e-3 * tilt
        mujoco.mj_forward(m, d)
        images, models, blobs, uv_true = [], [], [], []
        for cam in cams:
            image = _area_render(w.eye_rig, cam, supersample)
            model = w.eye_rig.camera_model(cam)
            uv = model.project_world(d.geom_xpos[gid])
            depth = (invert_transform(model.T_world_cam) @ np.append(d.geom_xpos[gid], 1.0))[2]
            radius = BLOB_RADIUS_SCALE * model.intrinsics.fx * m.geom_size[gid].max() / depth
            images.append(image)
            models.append(model)
            blobs.append(_blob(lut.posterior(image), uv, radius))
            uv_true.append(uv)
        c_px = np.eye(2) * MATCH_STD_PX ** 2
        ms = StereoRig(models[0], models[1], StereoParams()).match_many(
            images[0], images[1], [blobs[0][0]], [blobs[0][1]], [blobs[1][0]], [blobs[1][1]],
            c_px, c_px, [lut], MATCH_STD_PX)[0]
        disparity = uv_true[0][0] - uv_true[1][0]
        rows.append((float(tilt), float(uv_true[0][1]),
                     float(blobs[0][0][0] - blobs[1][0][0] - disparity),
                     float(ms.uv_left[0] - ms.uv_right[0] - disparity) if ms.ok else np.nan,
                     float(ms.score)))
    w.eye_rig.close()
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--step", type=float, default=0.1, help="tilt step (mrad)")
    ap.add_argument("--range", type=float, default=1.0, help="tilts from -RANGE to +RANGE")
    ap.add_argument("--supersample", type=int, default=1,
                    help="render N x N samples per pixel and average them (area integration)")
    ap.add_argument("overrides", nargs="*", help="scenario overrides, KEY=VALUE")
    args = ap.parse_args()
    tilts = np.arange(-args.range, args.range + 1e-9, args.step)
    for tilt, row, centroid, stereo, score in tilt_sweep(args.overrides, tilts,
                                                         args.supersample):
        print(f"tilt {tilt:+.2f} mrad  head row {row:.3f} px  disparity error: centroids "
              f"{centroid:+.3f} px, stereo {stereo:+.3f} px (ZNCC {score:.3f})")


if __name__ == "__main__":
    main()
