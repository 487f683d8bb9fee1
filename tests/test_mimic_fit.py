"""Mimicry that fits the robot: large motions are scaled into the robot's reach, not clamped.

The issue's goal: a 0.35 m-amplitude wave at 1.0 m mimicked with clamped fraction <= 2 % and
RMSE against the (scaled) target <= 20 mm, oracle and tracked. Measured when the thresholds
were set (seed 0): oracle 5.6 mm, clamped 0, no joint on a limit band, scale 1.04 -> 1.01;
tracked (mimicry from 0.5 s, the hand then 0.16 m off the wave's centre) 13.8 mm, clamped 0,
scale 1.04 -> 0.71. Re-measured 2026-11-29: oracle 5.6-5.7 mm (relative, mirrored, left), no tick
clamped and no joint-limit hit; tracked 14.3 mm, none clamped; the tests hold these, tighter
than the issue's goal. Before (ready pose with the arm 0.35 rad from its adduction stop, scale 1):
oracle 17.9 mm kinematic IK error and 26 % of ticks clamped.
"""

from __future__ import annotations

import pytest

from humimic.run import run_one
from humimic.scenario import load_scenario

pytestmark = pytest.mark.slow

FAST = ["cameras.resolution=[80, 60]", "output.plots=false", 'output.rerun="off"']
BIG_WAVE = ["human.distance=1.0", "human.motion.amplitude=0.35", "human.motion.period=2.6",
            "human.motion.arc_radius=0.45"]
#: robot arm (0.344 + 0.35 m) over the avatar's (0.326 + 0.341 m)
AUTO_SCALE = 0.694 / 0.667


def _run(root, tmp_path, name, overrides, duration, fast=FAST):
    sc = load_scenario(root / "scenarios" / f"{name}.yaml", [*fast, *overrides],
                       duration=duration)
    return run_one(sc, tmp_path, rerun="off", progress=False)


@pytest.mark.parametrize("mapping", [
    [],                                                              # right hand -> R_palm
    ["mimic.mode=mirrored", "mimic.map={right_hand: L_palm}"],       # mirror image
    ["human.motion.hand=left", "mimic.map={left_hand: L_palm}"],     # the left hand
], ids=["relative", "mirrored", "left"])
def test_a_large_wave_fits_without_clamping(root, tmp_path, mapping):
    m = _run(root, tmp_path, "mimic_wave", [*BIG_WAVE, *mapping], duration=5.5)["mimicry"]
    site = "R_palm" if not mapping else "L_palm"
    s = m[site]
    assert s["status"] == "ok"
    assert s["clamped_fraction"] == 0.0         # measured 0 (all three)
    assert s["rmse_mm"] <= 15.0                 # measured 5.6-5.7 mm
    assert s["scale_initial"] == pytest.approx(AUTO_SCALE, abs=2e-3)
    assert 0.8 <= s["scale"] <= s["scale_initial"]
    assert s["joint_limit_hits"] == 0           # measured 0


def test_a_large_tracked_wave_fits_without_clamping(root, tmp_path):
    m = _run(root, tmp_path, "mimic_tracked_wave", BIG_WAVE, duration=6.0, fast=FAST[1:])
    palm = m["mimicry"]["R_palm"]
    assert palm["status"] == "ok", palm
    assert palm["clamped_fraction"] == 0.0      # measured 0
    assert palm["rmse_mm"] <= 20.0              # measured 13.8, 14.3 mm
    assert 0.5 <= palm["scale"] < palm["scale_initial"]


def test_a_motion_twice_too_large_is_scaled_down_and_reported(root, tmp_path):
    """At scale 2 the wave leaves the reach; without the fit the clamp takes it (and the error
    with it), with the fit the scale settles and the clamp lets go."""
    over = ["human.motion.amplitude=0.3", "mimic.scale=2.0"]
    fitted = _run(root, tmp_path / "fit", "mimic_wave", over, duration=4.0)["mimicry"]["R_palm"]
    clamped = _run(root, tmp_path / "nofit", "mimic_wave", [*over, "mimic.fit.enabled=false"],
                   duration=4.0)["mimicry"]["R_palm"]
    assert clamped["scale"] == 2.0 and clamped["clamped_fraction"] >= 0.2
    assert fitted["scale_initial"] == 2.0 and fitted["scale"] <= 1.5
    assert fitted["clamped_fraction"] <= 0.5 * clamped["clamped_fraction"]
    assert fitted["rmse_mm"] <= 0.5 * clamped["rmse_mm"]
