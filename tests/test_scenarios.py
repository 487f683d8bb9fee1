"""Every scenario in scenarios/ validates and runs end to end (shortened), and a run writes
what the README promises; the same seed gives the same metrics."""

from __future__ import annotations

import json

import pytest

from humimic.metrics.tracking import FILTER_SETTLE_S
from humimic.paths import SCENARIOS_DIR
from humimic.run import main, run_one
from humimic.scenario import load_scenario

SCENARIOS = sorted(p.name for p in SCENARIOS_DIR.glob("*.yaml"))
WALL_KEYS = {"wall_time_s", "loop_wall_time_s", "realtime_factor", "mean_ms", "total_s",
             "solve_ms_mean", "solve_ms_p99"}


def test_there_are_scenarios_for_every_motion_kind():
    kinds = {load_scenario(SCENARIOS_DIR / n).human.motion.kind for n in SCENARIOS}
    assert {"static", "wave", "axes", "point", "head_sweep", "bvh"} <= kinds


@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_validates(name):
    load_scenario(SCENARIOS_DIR / name)  # raises on anything the schema rejects


def smoke_duration(scenario) -> float:
    """Simulated seconds a scenario needs before each of its stages scores something: the
    detection phase, a few frames to settle a blob, the filter's settle time and a margin;
    mimicry's start (if within the run) and enough servo ticks. Never longer than the
    scenario."""
    need = 0.5
    if scenario.perception is not None:
        need = max(need, scenario.perception.detection.period + 0.3
                   + (FILTER_SETTLE_S + 0.4 if scenario.filter is not None else 0.0))
    if scenario.mimic is not None and scenario.mimic.start < scenario.duration:
        need = max(need, scenario.mimic.start + 0.3)   # (a later start: the eyes' gaze alone)
    return min(need, scenario.duration)


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_runs_end_to_end_and_every_stage_scores(name, tmp_path):
    scenario = load_scenario(SCENARIOS_DIR / name, ["output.plots=false"])
    duration = smoke_duration(scenario)
    scenario = load_scenario(SCENARIOS_DIR / name, ["output.plots=false"], duration=duration)
    metrics = run_one(scenario, tmp_path, rerun="off", progress=False)
    assert metrics["sim_time_s"] == pytest.approx(duration, abs=1e-6)
    assert not metrics["interrupted"] and not metrics["mujoco_warnings"]
    assert (tmp_path / "metrics.json").is_file()
    if scenario.cameras.enabled:
        assert metrics["frames"] > 0
    if scenario.sensors.head_camera.enabled:
        assert metrics["wearable"]["headcam_frames"] > 0
    if scenario.perception is not None:
        tracking = metrics["tracking"]
        assert any(t["raw_rmse_mm"] is not None for t in tracking.values()), tracking
        assert (tmp_path / "tracking.npz").is_file()  # archived without plots
        if scenario.filter is not None:
            assert any(t.get("filtered_rmse_mm") is not None for t in tracking.values())
    trackers = getattr(scenario, "trackers", {}) or {}
    gated = {cfg.near.module: owner for owner, cfg in trackers.items()
             if getattr(cfg, "near", None) is not None}
    for name in trackers:  # every tracker ran and scored; a near module only once chosen
        if name in gated:
            assert metrics["trackers"][gated[name]]["modules"]["frames"], metrics["trackers"]
            continue
        assert metrics["trackers"][name]["frames"] > 0, metrics["trackers"][name]
        assert metrics["trackers"][name]["frames_per_s"] is not None, name
    if scenario.mimic is not None and scenario.mimic.mode == "joints":
        assert metrics["mimicry"]["joints"]["mode"] == "joints"
    elif scenario.mimic is not None and scenario.mimic.start < scenario.duration:
        for site in scenario.mimic.map.values():   # (a later start: the eyes' gaze alone)
            palm = metrics["mimicry"][site]
            assert palm["status"] == "ok" and palm["rmse_mm"] is not None, palm
        assert metrics["latency_ms"]["end_to_end"] is not None


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
    _check_truth_sites_in_rrd(out)


def _check_truth_sites_in_rrd(out):
    """The 3-D view's ground-truth sites are the World's, at the pose rate (30 Hz)."""
    import numpy as np
    from rerun.chunk import RrdReader

    from humimic.rngs import Rngs
    from humimic.world.world import World

    scenario = load_scenario(out / "scenario.resolved.yaml")
    world = World(scenario, Rngs(scenario.seed))
    rows = [chunk.to_record_batch() for chunk in RrdReader(out / "run.rrd").stream()
            if chunk.entity_path == "/world/truth/sites"]
    times = np.concatenate([rb.column("sim_time").cast("int64").to_numpy() for rb in rows])
    points = [np.array(p) for rb in rows for p in rb.column("Points3D:positions").to_pylist()]
    assert len(times) == 12  # 0.4 s at 30 Hz
    for t_ns, p in zip(times, points, strict=True):
        k = int(round(t_ns * 1e-9 * scenario.timing.physics_rate))
        np.testing.assert_allclose(p, world.gt.pos[k], atol=1e-6)  # float32 in the .rrd
    world.close()


def _strip_wall(value):
    if isinstance(value, dict):
        return {k: _strip_wall(v) for k, v in value.items() if k not in WALL_KEYS}
    return value


@pytest.mark.slow
def test_same_seed_same_metrics_different_seed_different_metrics(tmp_path):
    """The whole noisy loop (pixel noise, detection, filter, mimicry) is reproducible."""
    def run(seed, name):
        scenario = load_scenario(SCENARIOS_DIR / "mimic_tracked_wave.yaml", duration=1.2,
                                 seed=seed, overrides=["cameras.noise_std=2.0",
                                                       "output.plots=false"])
        return _strip_wall(run_one(scenario, tmp_path / name, rerun="off", progress=False))

    a, b, c = run(3, "a"), run(3, "b"), run(4, "c")
    assert a == b
    assert a["tracking"]["right_hand"]["raw_rmse_mm"] != c["tracking"]["right_hand"]["raw_rmse_mm"]


def test_ctrl_c_still_writes_metrics_and_a_readable_recording(tmp_path, monkeypatch):
    """A KeyboardInterrupt in the loop ends the run cleanly with what was simulated so far."""
    from rerun.chunk import RrdReader

    from humimic.pipeline import build
    from humimic.pipeline.stage import Stage

    class Interrupt(Stage):
        name = "interrupt"

        def servo(self, t, bus):
            if t >= 0.25:
                raise KeyboardInterrupt

    real = build.build_stages
    monkeypatch.setattr("humimic.run.build_stages",
                        lambda *a: [*real(*a), Interrupt()])
    scenario = load_scenario(SCENARIOS_DIR / "wave.yaml", duration=2.0)
    metrics = run_one(scenario, tmp_path, rerun="save", progress=False)
    assert metrics["interrupted"] is True
    assert metrics["sim_time_s"] == pytest.approx(0.25, abs=0.01)
    assert json.loads((tmp_path / "metrics.json").read_text())["interrupted"] is True
    entities = {chunk.entity_path for chunk in RrdReader(tmp_path / "run.rrd").stream()}
    assert "/world/cameras/L_wide/image" in entities and "/world/human/head" in entities


@pytest.mark.parametrize("name, tracker", [("menezes_fig9_leave_return.yaml", "icu"),
                                           ("menezes_gest_reach.yaml", "gest"),
                                           ("fig12_tbp_pointing.yaml", "tbp"),
                                           ("schmidt_side.yaml", "kpf")])
def test_every_tracker_kind_plots_its_error(tmp_path, name, tracker):
    """A person would rather look than read: each tracker writes ``tracker_<name>.png``, and
    the report page embeds it."""
    scenario = load_scenario(SCENARIOS_DIR / name, ["output.plots=true"], duration=0.6)
    run_one(scenario, tmp_path, rerun="off", progress=False)
    assert (tmp_path / f"tracker_{tracker}.png").stat().st_size > 10_000
    from humimic.report.page import load_run

    assert [h for p, h in load_run(tmp_path).images if p.name == f"tracker_{tracker}.png"] == [
        f"Tracker {tracker}: its error against the ground truth over time"]
