"""Colour models learned per scenario (``perception.color_model: auto``): first-run cost
(rendered, fitted, tabulated, stored) and cached cost (hashed and loaded), and how well the
learned model separates the person's skin from the rest of the view.

Goals (issue 9): first run <= 2 s, cached <= 50 ms.

Run: ``python benchmarks/bench_colors.py [--repeats N] [--scenario S ...]``. Every repeat uses an
empty cache directory for the first run, then loads the entry it wrote.
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import numpy as np

from humimic.paths import SCENARIOS_DIR
from humimic.perception.blobs.build import check_perception
from humimic.perception.cues.auto_colors import learned_lut
from humimic.perception.cues.learn_colors import frame_pixels, material_geoms, trim_dark
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.world.world import World

SCENARIOS = ("ude_wave_tracking", "ude_static_hand_foveal")


def separation(world, cams, lut) -> tuple[float, float]:
    """Fractions of skin / other pixels (full scene, noisy, 3 poses; the face's darkest
    features are not skin: ``trim_dark``) with colour density > 1."""
    geoms = material_geoms(world.scene.model, "skin")
    ticks = np.array([0, world.n_ticks // 2, world.n_ticks - 1])
    pos, neg = frame_pixels(world, list(cams), ticks, geoms, world.scenario.cameras.noise_std,
                            np.random.default_rng(7), negatives_per_frame=5000)
    return (float((lut.lookup(trim_dark(np.concatenate(pos))) > 1.0).mean()),
            float((lut.lookup(np.concatenate(neg)) > 1.0).mean()))


def bench(name: str, repeats: int, overrides: list[str]) -> None:
    scenario = load_scenario(SCENARIOS_DIR / f"{name}.yaml", overrides)
    world = World(scenario, Rngs(scenario.seed))
    try:
        cams = check_perception(scenario, world)
        world.eye_rig.prepare()  # GL contexts: paid by every run, learned or not
        first, cached = [], []
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as tmp:
                os.environ["HUMIMIC_CACHE_DIR"] = tmp
                t0 = time.perf_counter()
                a = learned_lut(world, list(cams))
                first.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                b = learned_lut(world, list(cams))
                cached.append(time.perf_counter() - t0)
                assert not a.cached and b.cached
        hit, false = separation(world, cams, b.lut)
    finally:
        world.close()
    print(f"{name:28s} {' '.join(overrides) or '(as written)':38s} first run "
          f"{statistics.median(first):6.3f} s  cached {1e3 * statistics.median(cached):6.1f} ms"
          f"  skin p>1 {100 * hit:5.1f} %  others p>1 {100 * false:5.2f} %")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--scenario", nargs="+", default=list(SCENARIOS))
    p.add_argument("--set", dest="overrides", action="append", default=[])
    args = p.parse_args()
    for name in args.scenario:
        bench(Path(name).stem, args.repeats, args.overrides)


if __name__ == "__main__":
    main()
