"""How far the rendered silhouettes of still targets put their stereo disparity off, from the
renderer's whole-pixel rasterisation alone: per distance, each eye's segmentation of the head
and of the hanging left hand (noise-free, nothing else drawn), its centroid against the
projection of the part's centre, and the difference between the eyes (px).

``python benchmarks/raster_disparity.py [DISTANCE ...]`` (default 1.2 1.25 1.3 1.35 1.4 1.5;
``ude_wave_tracking``'s person, seed 1, 200 physics ticks in). Notes:
``docs/ude_perception_notes.md``, "Still targets at other distances".
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import sys  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from humimic.rngs import Rngs  # noqa: E402
from humimic.scenario.load import load_scenario  # noqa: E402
from humimic.world.world import World  # noqa: E402

PARTS = {"head": "human/head", "left_hand": "human/l_hand"}


def silhouette_offsets(distance: float, tick: int = 200) -> dict[str, tuple[float, float]]:
    """Per part: (left-eye centroid - projection, disparity error) in px along u."""
    sc = load_scenario("scenarios/ude_wave_tracking.yaml",
                       [f"human.distance={distance}", "cameras.noise_std=0"])
    w = World(sc, Rngs(sc.seed))
    m, d = w.scene.model, w.scene.data
    w.apply_human(tick)
    mujoco.mj_forward(m, d)
    out = {}
    for part, geom in PARTS.items():
        gid = m.geom(geom).id
        du = []
        for cam in w.eye_cameras:
            seg = w.eye_rig.render_ideal(cam, segmentation=True, only=np.array([gid]))
            v, u = np.nonzero(seg[..., 0] == gid)
            du.append(u.mean() - w.eye_rig.camera_model(cam).project_world(d.geom_xpos[gid])[0])
        out[part] = (du[0], du[0] - du[1])
    w.eye_rig.close()
    return out


def main(argv: list[str]) -> None:
    for distance in [float(a) for a in argv] or [1.2, 1.25, 1.3, 1.35, 1.4, 1.5]:
        r = silhouette_offsets(distance)
        print(f"{distance:.2f} m  " + "  ".join(
            f"{p}: left {a:+.3f} px, disparity error {b:+.3f} px" for p, (a, b) in r.items()))


if __name__ == "__main__":
    main(sys.argv[1:])
