"""Every scenario in scenarios/ validates and runs end to end (shortened), and a run writes
what the README promises; the same seed gives the same metrics."""

from __future__ import annotations

import json

import pytest

from humimic.paths import SCENARIOS_DIR
from humimic.run import main, run_one
from humimic.scenario import load_scenario

SCENARIOS = sorted(p.name for p in SCENARIOS_DIR.glob("*.yaml"))
WALL_KEYS = {"wall_time_s", "loop_wall_time_s", "realtime_factor", "mean_ms", "total_s"}


def test_there_are_scenarios_for_every_motion_kind():
    kinds = {load_scenario(SCENARIOS_DIR / n).human.motion.kind for n in SCENARIOS}
    assert {"static", "wave", "axes", "point", "head_sweep", "bvh"} <= kinds


@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_validates(name):
    scenario = load_scenario(SCENARIOS_DIR / name)
    assert scenario.name and scenario.duration > 0


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_runs_end_to_end(name, tmp_path):
    scenario = load_scenario(SCENARIOS_DIR / name, duration=0.5)
    metrics = run_one(scenario, tmp_path, rerun="off", progress=False)
    assert metrics["sim_time_s"] == pytest.approx(0.5, abs=1e-6)
    assert not metrics["interrupted"] and not metrics["mujoco_warnings"]
    assert (tmp_path / "metrics.json").is_file()


def test_cli_run_writes_outputs(tmp_path):
    out = tmp_path / "run"
    code = main([str(SCENARIOS_DIR / "wave.yaml"), "--out", str(out), "--duration", "0.4",
                 "--rerun", "save", "--quiet", "--set", "human.distance=1.4"])
    assert code == 0
    metrics = json.loads((out / "metrics.json").read_text())
    for key in ("scenario", "seed", "sim_time_s", "wall_time_s", "realtime_factor", "stages"):
        assert key in metrics
    for stage in ("physics", "render"):
        assert metrics["stages"][stage]["mean_ms"] > 0
    assert (out / "run.rrd").stat().st_size > 10_000
    assert (out / "ground_truth.png").stat().st_size > 5_000
    resolved = (out / "scenario.resolved.yaml").read_text()
    assert "distance: 1.4" in resolved


def _strip_wall(value):
    if isinstance(value, dict):
        return {k: _strip_wall(v) for k, v in value.items() if k not in WALL_KEYS}
    return value


def test_same_seed_same_metrics(tmp_path):
    scenario = load_scenario(SCENARIOS_DIR / "wave.yaml", duration=0.5)
    a = run_one(scenario, tmp_path / "a", rerun="off", progress=False)
    b = run_one(scenario, tmp_path / "b", rerun="off", progress=False)
    assert _strip_wall(a) == _strip_wall(b)
