"""Sweep files: validation (exit 2, file, line and dotted key named, before any run), run
naming and expansion, metric flattening and selection. Nothing here runs a simulation."""

from __future__ import annotations

import pytest

from humimic.paths import SCENARIOS_DIR
from humimic.scenario import load_scenario
from humimic.sweep.__main__ import main
from humimic.sweep.config import load_sweep
from humimic.sweep.grid import expand, short_keys, value_text
from humimic.sweep.plan import plan_sweep
from humimic.sweep.runs import completed_metrics
from humimic.sweep.summary import flatten, select_metrics

WAVE = SCENARIOS_DIR / "wave.yaml"


def sweep_file(tmp_path, body: str, name: str = "s.yaml"):
    path = tmp_path / name
    path.write_text(f"scenario: {WAVE}\n" + body)
    return path


BAD = [
    # (body, expected fragments of the one-line error)
    ("grids: {human.distance: [1.0]}\n", ["s.yaml:2: grids: unknown key", "did you mean 'grid'"]),
    ("grid:\n  filter_b: [1]\n  human.distnce: [1.0]\n",
     ["s.yaml:4: grid.human.distnce: unknown key in scenario", "did you mean 'distance'"]),
    ("grid:\n  nosuch.b: [10, 27.5]\n", ["s.yaml:3: grid.nosuch.b: unknown key in scenario",
                                         "(at nosuch)"]),
    ("seeds: 2\ngrid:\n  human.distance: [1.0, 0.1]\n",
     ["s.yaml:4: grid.human.distance: out of range in scenario", "(got 0.1)", "> 0.3"]),
    ("grid:\n  human.distance: 1.0\n", ["s.yaml:3: grid.human.distance: Input should be a "
                                        "valid list"]),
    ("list:\n  - {human.motion.kind: wav}\n",
     ["s.yaml:3: list.0.human.motion.kind: unknown kind", "did you mean 'wave'"]),
    ("seeds: 0\n", ["s.yaml:2: seeds: must be a number of seeds"]),
    ("seeds: [1, 1]\n", ["s.yaml:2: seeds:"]),
    ("grid: {seed: [1, 2]}\n", ["s.yaml:2: grid:", "use the sweep's 'seeds'"]),
    ("set: {cameras.rate: -5}\n", ["s.yaml:2: set.cameras.rate: out of range"]),
    ("grid:\n  human.distance: [1.0]\nlist:\n  - {human.distance: 2.0}\n",
     ["s.yaml:5: list.0.human.distance: also varied by the grid"]),
    ("grid:\n  human.distance: [1.0, 1.0]\n", ["grid.human.distance: values repeat"]),
    ("grid: [1, 2]\n", ["s.yaml:2: grid:"]),
]


@pytest.mark.parametrize(("body", "fragments"), BAD)
def test_bad_sweep_file_exits_2_naming_file_and_key(tmp_path, capsys, body, fragments):
    path = sweep_file(tmp_path, body)
    out = tmp_path / "out"
    assert main([str(path), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and len(err.splitlines()) == 1
    for fragment in fragments:
        assert fragment in err, err
    assert not out.exists()  # nothing ran


def test_missing_files_exit_2(tmp_path, capsys):
    assert main([str(tmp_path / "nope.yaml")]) == 2
    assert "sweep file not found" in capsys.readouterr().err
    path = tmp_path / "s.yaml"
    path.write_text("scenario: missing.yaml\n")
    assert main([str(path)]) == 2
    assert "s.yaml:1: scenario: scenario file not found" in capsys.readouterr().err


def test_every_shipped_sweep_file_loads(root):
    for path in sorted((root / "sweeps").glob("*.yaml")):
        sweep = load_sweep(path)
        assert sweep.scenario_path.is_file(), path


def test_expansion_grid_times_list_times_seeds(tmp_path):
    path = sweep_file(tmp_path, "grid:\n  human.distance: [0.8, 1.2]\n  cameras.noise_std: [0, 4]\n"
                                "list:\n  - {human.lateral: 0.1}\n  - {lighting.ambient: 0.5}\n"
                                "seeds: [3, 7]\n")
    runs = expand(load_sweep(path), scenario_seed=1)
    assert len(runs) == 2 * 2 * 2 * 2
    assert runs[0].name == "distance=0.8__noise_std=0__lateral=0.1__seed=3"
    assert runs[1].name == "distance=0.8__noise_std=0__lateral=0.1__seed=7"
    assert runs[2].name == "distance=0.8__noise_std=0__ambient=0.5__seed=3"
    assert len({r.name for r in runs}) == len(runs)
    assert [o.key for o in runs[0].overrides] == ["human.distance", "cameras.noise_std",
                                                  "human.lateral"]
    assert expand(load_sweep(path)) == runs  # deterministic


def test_seeds_default_to_the_scenarios_own(tmp_path):
    runs = expand(load_sweep(sweep_file(tmp_path, "")), scenario_seed=load_scenario(WAVE).seed)
    assert [(r.name, r.seed) for r in runs] == [("seed=1", 1)]
    runs = expand(load_sweep(sweep_file(tmp_path, "seeds: 3\n")))
    assert [r.seed for r in runs] == [0, 1, 2]


def test_run_names_are_filesystem_safe_and_distinct():
    assert short_keys(["cameras.noise_std", "mimic.oracle.noise_std", "human.distance"]) == {
        "cameras.noise_std": "cameras.noise_std",
        "mimic.oracle.noise_std": "oracle.noise_std", "human.distance": "distance"}
    assert value_text(27.5) == "27.5" and value_text(True) == "true"
    assert value_text([320, 240]) == "320_240"
    for weird in ("a/b c", {"kind": "wave", "period": 2.0}, "x" * 50):
        text = value_text(weird)
        assert text.startswith("h") and len(text) == 9 and "/" not in text
    assert value_text("a b") != value_text("a_b")


def test_plan_validates_every_generated_scenario(tmp_path):
    path = sweep_file(tmp_path, "set: {duration: 0.5}\ngrid:\n  human.distance: [0.8, 2.0]\n"
                                "seeds: 2\n")
    planned = plan_sweep(load_sweep(path), tmp_path / "out")
    assert [(p.scenario.human.distance, p.scenario.seed) for p in planned] == [
        (0.8, 0), (0.8, 1), (2.0, 0), (2.0, 1)]
    assert all(p.scenario.duration == 0.5 and not p.scenario.output.plots for p in planned)
    assert planned[0].out_dir == (tmp_path / "out" / "distance=0.8__seed=0").resolve()


def test_stale_results_are_not_complete(tmp_path):
    """A run directory counts as complete only for the very scenario that produced it."""
    import json

    from humimic.scenario import dump_scenario

    scenario = load_scenario(WAVE, duration=0.3)
    (tmp_path / "scenario.resolved.yaml").write_text(dump_scenario(scenario))
    (tmp_path / "metrics.json").write_text(json.dumps({"sim_time_s": 0.3,
                                                       "interrupted": False}))
    assert completed_metrics(tmp_path, scenario) is not None
    assert completed_metrics(tmp_path, load_scenario(WAVE, duration=0.4)) is None
    (tmp_path / "metrics.json").write_text(json.dumps({"sim_time_s": 0.1,
                                                       "interrupted": True}))
    assert completed_metrics(tmp_path, scenario) is None
    (tmp_path / "metrics.json").write_text("{truncated")
    assert completed_metrics(tmp_path, scenario) is None


def test_flatten_and_metric_patterns():
    flat = flatten({"a": 1, "tracking": {"head": {"rmse_mm": 2.0, "std_mm": [1, 2, 3]}},
                    "mimicry": {"R_palm": {"rmse_mm": 3.0, "interpolation": {"hold": {
                        "rmse_mm": 4.0}}}}})
    assert flat["tracking.head.std_mm.2"] == 3
    cols = sorted(flat)
    assert select_metrics(["mimicry.*.rmse_mm"], cols) == ["mimicry.R_palm.rmse_mm"]
    assert select_metrics(["mimicry.**.rmse_mm"], cols) == [
        "mimicry.R_palm.interpolation.hold.rmse_mm", "mimicry.R_palm.rmse_mm"]
    assert select_metrics(["tracking.*.std_mm.*", "nothing.*"], cols) == [
        "tracking.head.std_mm.0", "tracking.head.std_mm.1", "tracking.head.std_mm.2"]
