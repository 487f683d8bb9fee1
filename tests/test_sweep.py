"""Sweeps end to end: a 2-seed x 2-distance sweep of a short wave scenario on the local backend
(and on Ray when it is installed): summary files, resuming, failed runs, and agreement with a
direct ``run_one``."""

from __future__ import annotations

import csv
import json
import os
import sys

import pytest

from humimic.paths import SCENARIOS_DIR
from humimic.run import run_one
from humimic.scenario import load_scenario
from humimic.sweep import runs as sweep_runs
from humimic.sweep.__main__ import main
from humimic.sweep.config import load_sweep
from humimic.sweep.driver import run_sweep

WALL_KEYS = {"wall_time_s", "loop_wall_time_s", "realtime_factor", "mean_ms", "total_s"}
DURATION = 0.3
DISTANCES = (1.0, 1.5)


def write_sweep(directory, **extra) -> object:
    text = (f"scenario: {SCENARIOS_DIR / 'wave.yaml'}\n"
            f"set: {{duration: {DURATION}}}\n"
            f"grid:\n  human.distance: [{DISTANCES[0]}, {DISTANCES[1]}]\n"
            "seeds: 2\n")
    text += "".join(f"{k}: {v}\n" for k, v in extra.items())
    path = directory / "small.yaml"
    path.write_text(text)
    return path


def strip_wall(value):
    if isinstance(value, dict):
        return {k: strip_wall(v) for k, v in value.items() if k not in WALL_KEYS}
    return value


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    """The small sweep run once with two loky workers."""
    d = tmp_path_factory.mktemp("sweep")
    sweep = load_sweep(write_sweep(d))
    result = run_sweep(sweep, d / "out", jobs=2, progress=False)
    return sweep, result


def test_local_sweep_writes_runs_and_summary(local_sweep):
    _, result = local_sweep
    out = result.out_dir
    names = sorted(p.name for p in result.planned)
    assert names == ["distance=1.0__seed=0", "distance=1.0__seed=1",
                     "distance=1.5__seed=0", "distance=1.5__seed=1"]
    assert all(o.status == "ok" and not o.cached for o in result.outcomes.values())
    for name in names:
        metrics = json.loads((out / name / "metrics.json").read_text())
        assert metrics["sim_time_s"] == pytest.approx(DURATION)
        assert (out / name / "scenario.resolved.yaml").is_file()
    rows = list(csv.DictReader((out / "summary.csv").open()))
    assert [r["run"] for r in rows] == names
    assert {r["human.distance"] for r in rows} == {"1.0", "1.5"}
    assert {r["seed"] for r in rows} == {"0", "1"}
    assert all(float(r["realtime_factor"]) > 0 for r in rows)
    md = (out / "summary.md").read_text()
    assert "| human.distance | runs ok | realtime_factor |" in md
    assert md.count(" ± ") >= 2  # one mean ± std per grid point
    assert (out / "plots" / "realtime_factor.png").stat().st_size > 5_000
    assert len(json.loads((out / "sweep.json").read_text())["runs"]) == 4


def test_rerun_skips_complete_runs(local_sweep):
    sweep, result = local_sweep
    out = result.out_dir
    mtimes = {p.name: os.stat(p.out_dir / "metrics.json").st_mtime_ns for p in result.planned}
    again = run_sweep(sweep, out, jobs=1, progress=False)
    assert again.executed == [] and all(o.cached for o in again.outcomes.values())
    assert {p.name: os.stat(p.out_dir / "metrics.json").st_mtime_ns
            for p in again.planned} == mtimes
    # an incomplete run (no metrics.json) is the only one executed again
    (out / "distance=1.5__seed=1" / "metrics.json").unlink()
    third = run_sweep(sweep, out, jobs=1, progress=False)
    assert [o.name for o in third.executed] == ["distance=1.5__seed=1"]
    rows = list(csv.DictReader((out / "summary.csv").open()))
    assert [r["cached"] for r in rows] == ["True", "True", "True", "False"]


def test_sweep_run_equals_direct_run_one(local_sweep, tmp_path):
    _, result = local_sweep
    run = next(p for p in result.planned if p.name == "distance=1.5__seed=1")
    swept = json.loads((run.out_dir / "metrics.json").read_text())
    scenario = load_scenario(SCENARIOS_DIR / "wave.yaml", ["human.distance=1.5"], seed=1,
                             duration=DURATION)
    direct = run_one(scenario, tmp_path, rerun="off", progress=False)
    assert strip_wall(swept) == strip_wall(direct)


def test_a_failing_run_is_recorded_and_the_others_finish(tmp_path, monkeypatch, capsys):
    real = sweep_runs.run_one

    def flaky(scenario, out_dir, rerun=None, progress=True):
        if scenario.human.distance == DISTANCES[1]:
            raise RuntimeError("injected failure at run time")
        return real(scenario, out_dir, rerun=rerun, progress=progress)

    monkeypatch.setattr(sweep_runs, "run_one", flaky)
    path = write_sweep(tmp_path)
    out = tmp_path / "out"
    assert main([str(path), "--out", str(out), "--jobs", "1", "--quiet"]) == 1
    rows = {r["run"]: r for r in csv.DictReader((out / "summary.csv").open())}
    failed = [n for n, r in rows.items() if r["status"] == "failed"]
    assert sorted(failed) == ["distance=1.5__seed=0", "distance=1.5__seed=1"]
    for name in failed:
        assert rows[name]["error"] == "RuntimeError: injected failure at run time"
        assert "Traceback" in (out / name / "error.txt").read_text()
        assert not (out / name / "metrics.json").exists()
    assert all(rows[n]["status"] == "ok" for n in rows if n not in failed)
    md = (out / "summary.md").read_text()
    assert "## Failed runs" in md and "injected failure" in md
    assert "injected failure" in capsys.readouterr().out
    # fixed: a rerun executes only the failed runs
    monkeypatch.setattr(sweep_runs, "run_one", real)
    again = run_sweep(load_sweep(path), out, jobs=1, progress=False)
    assert sorted(o.name for o in again.executed) == failed
    assert not again.failed
    assert not (out / failed[0] / "error.txt").exists()


def test_ray_backend_runs_the_same_sweep(tmp_path):
    pytest.importorskip("ray", reason="ray is not installed (pip install 'humimic[cluster]')")
    sweep = load_sweep(write_sweep(tmp_path))
    result = run_sweep(sweep, tmp_path / "out", jobs=2, backend="ray", progress=False)
    assert sorted(o.status for o in result.outcomes.values()) == ["ok"] * 4
    assert all(not o.cached for o in result.outcomes.values())
    rows = list(csv.DictReader((tmp_path / "out" / "summary.csv").open()))
    assert len(rows) == 4 and all(r["status"] == "ok" for r in rows)


def test_a_local_ray_instance_runs_its_workers_at_normal_priority():
    """Ray nices its workers to 15: beside any busy process they starved (the sweep above took
    260 s instead of ~25 on a 2-core machine running the other tests)."""
    pytest.importorskip("ray", reason="ray is not installed (pip install 'humimic[cluster]')")
    from humimic.sweep.backends import ray_map

    def niceness() -> int:  # local, so Ray's pickler sends it by value (the worker cannot
        return os.nice(0)   # import this test module)

    assert list(ray_map(niceness, [()], jobs=1)) == [os.nice(0)]


def test_ray_backend_without_ray_exits_2_with_install_hint(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    path = write_sweep(tmp_path)
    assert main([str(path), "--out", str(tmp_path / "out"), "--backend", "ray"]) == 2
    err = capsys.readouterr().err
    assert "ray is not installed" in err and "pip install 'humimic[cluster]'" in err
    assert not (tmp_path / "out").exists()


def test_plot_lines_are_named_by_the_keys_that_tell_them_apart():
    """Keys swept together with the x axis (Table 1's particles and iterations of every
    tracker) are not in the line labels; an independent key is."""
    from humimic.sweep.plots import line_keys
    from humimic.sweep.summary import Group

    groups = [Group({"n": n, "it": 2 if n == 150 else 3, "other.n": n, "gesture": g})
              for n in (150, 250, 1000) for g in ("side", "angle")]
    assert line_keys(groups, ["gesture", "n", "it", "other.n"], "n") == ["gesture"]
    crossed = [Group({"n": n, "it": it}) for n in (150, 1000) for it in (2, 3)]
    assert line_keys(crossed, ["n", "it"], "n") == ["it"]
