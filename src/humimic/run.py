"""Run a scenario: ``python -m humimic.run SCENARIO.yaml [options]``.

Writes into ``--out`` (default ``runs/<name>-<seed>/``): ``scenario.resolved.yaml``,
``metrics.json``, PNG plots and ``run.rrd`` (open it with ``rerun run.rrd``). A bad scenario
prints one line and exits with status 2.
"""

from __future__ import annotations

from humimic import select_gl_backend
from humimic.heap import purge_freed_pages_at_once

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco
purge_freed_pages_at_once()  # and the recording's allocator, before anything imports rerun

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from humimic.errors import InputError, report_error
from humimic.heap import release_free_heap, tune_heap
from humimic.metrics.summary import print_summary, verdict_warning
from humimic.pipeline.build import build_stages
from humimic.pipeline.simulation import simulate
from humimic.report import write_report
from humimic.rngs import Rngs
from humimic.scenario import Scenario, dump_scenario, load_scenario
from humimic.scenario.errors import ScenarioError
from humimic.scenario.load import placed
from humimic.viz.blueprint import run_layout
from humimic.viz.plots import MAX_POINTS, plot_trajectories
from humimic.viz.rerun_columns import SERIES_CHUNK
from humimic.viz.rerun_log import SERIES, TRUTH, RerunLog, camera_entity
from humimic.world.world import World

#: Targets whose ground truth is always plotted and logged.
GT_TARGETS = ("head", "right_hand", "left_hand")


def default_out_dir(scenario: Scenario) -> Path:
    return Path("runs") / f"{scenario.name}-{scenario.seed}"


def run_one(scenario: Scenario, out_dir: str | Path | None = None, rerun: str | None = None,
            progress: bool = True) -> dict:
    """Run ``scenario`` (its own seed) and return the metrics written to ``metrics.json``."""
    wall0 = time.perf_counter()
    tune_heap()  # large blocks mapped on their own: a long run's heap does not fragment
    out = prepare_out_dir(Path(out_dir) if out_dir is not None else default_out_dir(scenario))
    (out / "scenario.resolved.yaml").write_text(dump_scenario(scenario))
    mode = rerun or scenario.output.rerun
    rngs = Rngs(scenario.seed)

    t0 = time.perf_counter()
    world = World(scenario, rngs)
    setup_s = time.perf_counter() - t0
    cameras = [camera_entity(n) for n in world.eye_cameras
               + (["headcam"] if world.head_rig is not None else [])]
    if getattr(scenario, "slam", None) is not None:  # the SLAM's image with Fig. 7's features
        from humimic.estimation.ekf.slam_stage import SLAM

        cameras.append(f"{SLAM}/camera")
    stages: list = []
    try:  # a live viewer gets the layout at once; the file, with the views that got data
        with RerunLog(world.scene, mode, out / "run.rrd",
                      recording_id=f"{scenario.name}-{scenario.seed}",
                      blueprint=run_layout(set(), []) if mode == "spawn" else None) as rlog:
            rlog.log_static_scene(groups=(0, 1, 2, 3) if scenario.human.wiimote else (0, 1, 2))
            stages = build_stages(scenario, world, rngs, rlog)
            result = simulate(world, stages, rlog, progress=progress)
            for stage in stages:
                stage.log(rlog)
            _log_ground_truth(rlog, world, result.ticks_done)
            rlog.send_blueprint(run_layout(rlog.logged, cameras))
        # scored once the recording is closed: the scores' whole-run columns do not add to
        # the recording's buffers at the run's peak; each phase after the loop starts from a
        # trimmed heap, so that its large blocks reuse the memory the previous one freed
        release_free_heap()
        metrics = _metrics(scenario, world, stages, result, setup_s, wall0)
        release_free_heap()
    finally:
        for stage in stages:
            stage.close()
        world.close()
    metrics["wall_time_s"] = time.perf_counter() - wall0
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, allow_nan=False))
    for stage in stages:
        stage.archive(out)
    if scenario.output.plots:
        release_free_heap()
        _plots(out, world, stages, result.ticks_done)
        # the report reads only the files: the run's records, caches and models go first,
        # so that its figure reuses their memory instead of adding to it
        del world, stages, result
        release_free_heap()
        write_report(out)
    return metrics


def check_out_dir(out: Path) -> None:
    """:class:`InputError` if ``out`` exists and is not a directory."""
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a directory")


def prepare_out_dir(out: Path) -> Path:
    """Create the output directory; :class:`InputError` if ``out`` is a file or cannot be made."""
    check_out_dir(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out {out}: cannot create the directory ({exc.strerror})") from None
    return out


def dry_run(scenario: Scenario) -> None:
    """Everything a run does before its first step -- build the world (scene, motion, ground
    truth, sensors) and the stages -- then close them: no simulation, no output files."""
    rngs = Rngs(scenario.seed)
    world = World(scenario, rngs)
    stages: list = []
    try:
        with RerunLog(world.scene, "off", None, recording_id=scenario.name) as rlog:
            stages = build_stages(scenario, world, rngs, rlog)
    finally:
        for stage in stages:
            stage.close()
        world.close()


def _metrics(scenario, world, stages, result, setup_s, wall0) -> dict:
    timer = result.timer
    timer.add("setup", setup_s)
    metrics = {
        "scenario": scenario.name,
        "seed": scenario.seed,
        "sim_time_s": result.sim_time_s,
        "wall_time_s": time.perf_counter() - wall0,
        "loop_wall_time_s": result.wall_time_s,
        "realtime_factor": result.sim_time_s / max(result.wall_time_s, 1e-9),
        "interrupted": result.interrupted,
        "frames": result.frames_published,
        "mujoco_warnings": {w: int(c) for w, c in _warnings(world).items()},
        "stages": timer.summary(),
    }
    deep_merge(metrics, world.faults.metrics())
    if world.person_view is not None:
        metrics["person_view"] = world.person_view
    for stage in stages:
        deep_merge(metrics, stage.metrics())
    return metrics


def deep_merge(into: dict, new: dict) -> dict:
    """Merge ``new`` into ``into`` recursively (stages may share sections like latency_ms)."""
    for key, value in new.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            deep_merge(into[key], value)
        else:
            into[key] = value
    return into


def _warnings(world) -> dict[str, int]:
    import mujoco

    return {mujoco.mjtWarning(i).name: int(w.number)
            for i, w in enumerate(world.scene.data.warning) if w.number}


def _log_ground_truth(rlog, world, ticks: int) -> None:
    """Ground truth at the pose rate (evaluated at those ticks only: it is computed on demand):
    the plotted targets as series, every site as points in the 3-D view (names on hover)."""
    gt = world.gt
    step = max(1, round(world.scenario.timing.physics_rate / world.scenario.output.pose_rate))
    ks = np.arange(0, ticks, step)
    for target in GT_TARGETS:
        rlog.log_series(f"{SERIES}/ground_truth/{target}", gt.t[ks], gt.p_base(target)[ks],
                        names=[f"{target} {a} (m)" for a in "xyz"])
    for k0 in range(0, len(ks), SERIES_CHUNK):  # as columns, a block at a time
        kb = ks[k0:k0 + SERIES_CHUNK]
        rlog.log_points_rows(f"{TRUTH}/sites", gt.t[kb], gt.pos[kb], colors=[40, 200, 40],
                             radii=0.01, labels=list(gt.targets))


def _plots(out: Path, world, stages, ticks: int) -> None:
    ks = np.arange(0, ticks, max(1, -(-ticks // MAX_POINTS)))  # what a plot draws
    series = {target: world.gt.p_base(target)[ks] for target in GT_TARGETS}
    plot_trajectories(out / "ground_truth.png", world.times[ks], series,
                      title="Ground truth, robot base frame", ylabel="position (m)")
    for stage in stages:
        stage.plots(out)
        release_free_heap()  # its figures, before the next stage's stack on them


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line on stderr (exit 2), like a bad scenario's;
    ``--help`` shows the usage."""

    def error(self, message: str):
        self.exit(2, f"error: {self.prog}: {message} (see --help)\n")


def _parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="python -m humimic.run", description=__doc__.split("\n")[0])
    p.add_argument("scenario", type=Path, help="scenario YAML file")
    p.add_argument("--out", type=Path, default=None, help="output directory")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    p.add_argument("--duration", type=float, default=None, help="override duration (s)")
    p.add_argument("--rerun", choices=["off", "save", "spawn"], default=None,
                   help="rerun recording (default: the scenario's output.rerun)")
    p.add_argument("--set", dest="overrides", action="append", default=[],
                   metavar="KEY=VALUE", help="override a scenario key, e.g. human.distance=1.5")
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary table")
    p.add_argument("--dry-run", action="store_true",
                   help="load and check the scenario, build the world and the stages, then stop "
                        "(no simulation, nothing written)")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    scenario = None
    try:
        scenario = load_scenario(args.scenario, args.overrides, seed=args.seed,
                                 duration=args.duration)
        if args.dry_run:
            if args.out is not None:
                check_out_dir(args.out)
            dry_run(scenario)
            return 0
        metrics = run_one(scenario, args.out, args.rerun, progress=not args.quiet)
    except ScenarioError as err:  # the world's and stages' checks name the scenario: the file
        if scenario is not None:
            err = placed(err, scenario.name, args.scenario, args.overrides, seed=args.seed,
                         duration=args.duration)
        return report_error(err)
    except InputError as err:
        return report_error(err)
    if not args.quiet:
        print_summary(metrics, args.out or default_out_dir(scenario))
    warning = verdict_warning(metrics)
    if warning:
        print(warning, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
