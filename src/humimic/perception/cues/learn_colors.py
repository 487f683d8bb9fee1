"""Learn a colour model off-line from rendered frames, MuJoCo segmentation as the labels.

``python -m humimic.perception.cues.learn_colors --out models/colors/skin.json [options]``

The person of a scenario (default ``scenarios/wave.yaml``) is rendered by the robot's eye
cameras at ``--frames`` instants spread over its motion, for each camera kind in ``--which``
(wide and foveal by default, so the model has seen both scales). The pixels whose segmentation
label is a geom of the avatar's colour class ``--material`` (``skin``: the hands and the face-
textured head, without its darkest features: :data:`DARK_FRACTION`) are the training set, with
the scenario's pixel noise added as in a real capture; a Gaussian mixture (Ude eqs. 6-7) is
fitted in ``--space`` (``rgb`` for skin, ``hs`` for coloured objects). Scenarios learn their own
model at start-up the same way (:mod:`humimic.perception.cues.auto_colors`); this command writes
one to a file.

It prints how well the model separates the material from the rest of the view: the fraction of
material pixels and of all other pixels whose colour density exceeds the uniform outlier's (1).
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from humimic.errors import InputError, report_error
from humimic.paths import SCENARIOS_DIR
from humimic.perception.cues.color_models import ColorModel, fit_color_model, save_color_model
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.sensors.cameras import add_pixel_noise
from humimic.world.names import COLOR_CLASSES, HUMAN_PREFIX
from humimic.world.world import World


@dataclass
class Samples:
    """Labelled pixels of the rendered frames."""

    positive: np.ndarray
    """(N, 3) uint8 pixels of the material."""
    negative: np.ndarray
    """(M, 3) uint8 pixels of everything else (a subsample)."""
    frames: int


def material_geoms(model: mujoco.MjModel, material: str) -> np.ndarray:
    """Ids of the avatar's geoms of ``material`` or of the colour class of that name
    (:data:`~humimic.world.names.COLOR_CLASSES`: ``skin`` is the hands' skin and the face)."""
    ids = []
    for name in COLOR_CLASSES.get(material, (material,)):
        try:
            ids.append(model.material(HUMAN_PREFIX + name).id)
        except KeyError:
            if name != material:  # a class member the scene lacks (e.g. no face texture)
                continue
            names = [model.material(i).name.removeprefix(HUMAN_PREFIX)
                     for i in range(model.nmat)
                     if model.material(i).name.startswith(HUMAN_PREFIX)]
            raise InputError(f"--material: the avatar has no material {material!r}; "
                             f"its materials: {', '.join(names)}") from None
    return np.flatnonzero(np.isin(model.geom_matid, ids))


DARK_FRACTION = 0.6
"""Pixels darker than this fraction of the class's median brightness are left out of the training
set: the face texture's eyes, brows and hair line are not skin, and a model that learns them
takes black for skin (shading scales skin colours along a ray through black; at 0.3 the learned
density at black was 1.4, above the uniform background's 1) and a beige shirt for skin (at 0.4
the wave's hand and head were not detected in a beige shirt; at 0.6: 0.95 and 0.97 of visible
frames, density at black 1e-5). (Leaving the whole texture out is worse: the head splits into
blobs along its mouth, which Ude & Atkeson's identity rules cannot name.)"""


def trim_dark(pixels: np.ndarray, fraction: float = DARK_FRACTION) -> np.ndarray:
    """``pixels (N, 3)`` without those whose brightness (mean of R, G, B) is below
    ``fraction`` times the median brightness."""
    pixels = np.asarray(pixels)
    if len(pixels) == 0:
        return pixels
    brightness = pixels.astype(np.float64).mean(axis=1)
    return pixels[brightness >= fraction * np.median(brightness)]


def label_mask(seg: np.ndarray, geoms: np.ndarray) -> np.ndarray:
    """Pixels of a segmentation render ``(H, W, 2)`` [object id, object type] on ``geoms``."""
    is_geom = seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
    return is_geom & np.isin(seg[..., 0], geoms)


def frame_pixels(world, cameras: list[str], ticks: np.ndarray, geoms: np.ndarray,
                 noise_std: float, rng: np.random.Generator, negatives_per_frame: int = 0
                 ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Pixels of ``geoms`` (and ``negatives_per_frame`` others per frame) in the ideal images of
    ``cameras`` of ``world`` at the person's poses of ``ticks`` (the robot as it is now), with
    pixel noise ``noise_std`` added. Without negatives only ``geoms`` are drawn (the others
    would only be thrown away; ~10x faster). The scene's state is restored afterwards."""
    m, d = world.scene.model, world.scene.data
    qpos, qvel = d.qpos.copy(), d.qvel.copy()
    only = None if negatives_per_frame else geoms
    pos, neg = [], []
    try:
        for tick in np.asarray(ticks).tolist():
            world.apply_human(tick)
            mujoco.mj_forward(m, d)
            for cam in cameras:
                image = world.eye_rig.render_ideal(cam, only=only)
                if noise_std > 0.0:
                    image = add_pixel_noise(image, noise_std, rng)
                mask = label_mask(world.eye_rig.render_ideal(cam, True, only), geoms)
                pos.append(image[mask])
                if negatives_per_frame:
                    rest = image[~mask]
                    if negatives_per_frame < len(rest):  # (all of them: no draw)
                        rest = rest[rng.choice(len(rest), negatives_per_frame, replace=False)]
                    neg.append(rest)
    finally:
        d.qpos[:], d.qvel[:] = qpos, qvel
        mujoco.mj_forward(m, d)
    return pos, neg


def collect(scenario, which: list[str], n_frames: int, rng: np.random.Generator,
            material: str = "skin", negatives_per_frame: int = 2000) -> Samples:
    """Render ``n_frames`` instants of ``scenario`` with each camera kind and label pixels."""
    pos, neg, frames = [], [], 0
    for kind in which:
        sc = scenario.model_copy(deep=True)
        sc.cameras.which = kind
        world = World(sc, Rngs(scenario.seed))
        try:
            geoms = material_geoms(world.scene.model, material)
            ticks = np.linspace(0, world.n_ticks - 1, n_frames).round().astype(int)
            p, n = frame_pixels(world, world.eye_cameras, ticks, geoms, sc.cameras.noise_std,
                                rng, negatives_per_frame)
            pos += p
            neg += n
            frames += len(p)
        finally:
            world.close()
    return Samples(trim_dark(np.concatenate(pos)), np.concatenate(neg), frames)


def separation(model: ColorModel, samples: Samples) -> tuple[float, float]:
    """Fractions of material / other pixels more likely under ``model`` than uniform (p > 1)."""
    return (float((model.likelihood(samples.positive) > 1.0).mean()),
            float((model.likelihood(samples.negative) > 1.0).mean()))


def learn(scenario, which: list[str], n_frames: int, space: str, n_components: int,
          rng: np.random.Generator, material: str = "skin", max_pixels: int = 30000
          ) -> tuple[ColorModel, Samples]:
    samples = collect(scenario, which, n_frames, rng, material)
    if len(samples.positive) < 50 * n_components:
        raise InputError(f"only {len(samples.positive)} pixels of material {material!r} are "
                         "visible in the rendered frames; choose a scenario that shows it")
    train = samples.positive
    if len(train) > max_pixels:
        train = train[rng.choice(len(train), max_pixels, replace=False)]
    model = fit_color_model(train, space, n_components, rng, name=material)
    return model, samples


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m humimic.perception.cues.learn_colors",
                                description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, required=True, help="output file (.json or .npz)")
    p.add_argument("--scenario", type=Path, default=SCENARIOS_DIR / "wave.yaml",
                   help="scenario whose person is rendered (default: scenarios/wave.yaml)")
    p.add_argument("--skin", type=float, nargs=3, metavar=("R", "G", "B"), default=None,
                   help="override human.skin (RGB in [0, 1])")
    p.add_argument("--material", default="skin", help="avatar material to learn (skin)")
    p.add_argument("--space", choices=["rgb", "hs"], default="rgb")
    p.add_argument("--components", type=int, default=3, help="Gaussians in the mixture")
    p.add_argument("--which", nargs="+", choices=["wide", "foveal"], default=["wide", "foveal"],
                   help="eye camera kinds to render")
    p.add_argument("--frames", type=int, default=12, help="instants per camera kind")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario key, e.g. lighting.ambient=0.4")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    overrides = list(args.overrides)
    if args.skin is not None:
        overrides.append(f"human.skin=[{', '.join(str(c) for c in args.skin)}]")
    try:
        if args.out.suffix not in (".json", ".npz"):
            raise InputError(f"--out must end in .json or .npz, got {args.out}")
        if not (1 <= args.components <= 10 and 1 <= args.frames <= 500):
            raise InputError("--components must be in 1..10 and --frames in 1..500")
        scenario = load_scenario(args.scenario, overrides)
        rng = np.random.default_rng(args.seed)
        model, samples = learn(scenario, args.which, args.frames, args.space, args.components,
                               rng, args.material)
    except InputError as err:
        return report_error(err)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    save_color_model(model, args.out)
    hit, false = separation(model, samples)
    print(f"{args.out}: {args.space} model of {args.material!r}, {len(model.weights)} "
          f"components, from {len(samples.positive)} pixels in {samples.frames} frames; "
          f"p > 1 on {100 * hit:.1f} % of {args.material} pixels and {100 * false:.2f} % of "
          "the others")
    return 0


if __name__ == "__main__":
    sys.exit(main())
