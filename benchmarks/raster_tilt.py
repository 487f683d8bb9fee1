"""How the still head's stereo disparity error moves when the robot's eyes tilt by a fraction of
a milliradian (as its head nods while its arm waves): noise-free renders of the whole scene,
each eye's head blob from the colour posterior (moments within 12 px of the head's projection),
matched by :class:`~humimic.perception.blobs.stereo.StereoRig` with the colour mask as the stage
matches; per tilt the head's image row and the disparity error (px) of the blob centroids and
of the stereo match against the projections of the head's centre.

``python benchmarks/raster_tilt.py [--step MRAD] [--range MRAD] [KEY=VALUE ...]``
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
from humimic.world.names import ROBOT_JOINTS  # noqa: E402
from humimic.world.world import World  # noqa: E402

SCENARIO = "scenarios/mimic_tracked_wave.yaml"
BLOB_RADIUS_PX = 12.0
MATCH_STD_PX = 0.04


def _blob(posterior: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Posterior-weighted centre and covariance (px) of the pixels near ``uv``."""
    h, w = posterior.shape
    vv, uu = np.mgrid[0:h, 0:w]
    wgt = np.where(np.hypot(uu - uv[0], vv - uv[1]) < BLOB_RADIUS_PX, posterior, 0.0)
    centre = np.array([(wgt * uu).sum(), (wgt * vv).sum()]) / wgt.sum()
    d = np.stack([uu - centre[0], vv - centre[1]], -1)
    return centre, np.einsum("hw,hwi,hwj->ij", wgt, d, d) / wgt.sum()


def tilt_sweep(overrides: list[str], tilts_mrad: np.ndarray) -> list[tuple[float, ...]]:
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
            image = w.eye_rig.render_ideal(cam)
            model = w.eye_rig.camera_model(cam)
            uv = model.project_world(d.geom_xpos[gid])
            images.append(image)
            models.append(model)
            blobs.append(_blob(lut.posterior(image), uv))
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
    ap.add_argument("overrides", nargs="*", help="scenario overrides, KEY=VALUE")
    args = ap.parse_args()
    tilts = np.arange(-args.range, args.range + 1e-9, args.step)
    for tilt, row, centroid, stereo, score in tilt_sweep(args.overrides, tilts):
        print(f"tilt {tilt:+.2f} mrad  head row {row:.3f} px  disparity error: centroids "
              f"{centroid:+.3f} px, stereo {stereo:+.3f} px (ZNCC {score:.3f})")


if __name__ == "__main__":
    main()
