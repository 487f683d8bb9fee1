"""Every humimic benchmark in one run: one table (median and interquartile range over repeats,
ours / peer ratios) and a JSON file.

    .venv/bin/python benchmarks/run_all.py [--repeats 7] [--quick] [--json PATH] [--only G ...]

Groups: ``world`` (physics step, eye-camera rendering, the world loop's real-time factor),
``stages`` (EM blob tracker 1/2/4 blobs, stereo ZNCC + triangulation, Kalman step, IK solve,
closed-loop real-time factor), ``peers`` (same inputs, same run: random-jerk filter vs
cv2.KalmanFilter and filterpy; EM tracker vs CamShift, time and centre error; ZNCC vs
cv2.matchTemplate). A stage that is not there yet is listed as skipped with the reason. The
machine, date, versions and the load average before and after are recorded: timings on a
shared machine are noisy, compare medians.
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import sys
import time
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import numpy as np
from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _harness import Peer, Row, fmt, row  # noqa: E402

GROUPS = ("world", "stages", "peers")
DEFAULT_JSON = Path(__file__).resolve().parent / "results" / "all.json"


def machine() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        mem_gib = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError):
        mem_gib = None
    import cv2
    import mujoco

    return {"cpu": cpu, "cores": os.cpu_count(), "memory_gib": mem_gib,
            "platform": platform.platform(), "python": platform.python_version(),
            "numpy": np.__version__, "opencv": cv2.__version__, "mujoco": mujoco.__version__,
            "mujoco_gl": os.environ.get("MUJOCO_GL")}


def world_rows(repeats: int) -> list[Row]:
    import bench_world as bw

    render = [("render 1 eye camera 320x240", ["L_wide"], (320, 240)),
              ("render 1 eye camera 640x480", ["L_wide"], (640, 480)),
              ("render stereo pair 320x240", ["L_wide", "R_wide"], (320, 240)),
              ("render all 4 eye cameras 320x240",
               ["L_wide", "R_wide", "L_foveal", "R_foveal"], (320, 240))]
    rows = [row("world", "physics step (robot + avatar)", bw.bench_physics(repeats), "us", 1e6,
                note="mj_step, 840 Hz model")]
    rows += [row("world", name, bw.bench_render(repeats, cams, size), "ms", 1e3,
                 note="MuJoCo offscreen render + readback per frame, "
                      f"MUJOCO_GL={os.environ.get('MUJOCO_GL')}")
             for name, cams, size in render]
    rows.append(row("world", "world loop, wide stereo 60 Hz 320x240, no stages",
                    bw.bench_world_loop(max(3, repeats // 2)), "x real time",
                    note="run_one, 3 s of the wave, physics 840 Hz"))
    return rows


def stage_rows(repeats: int, quick: bool, stereo_seq) -> list[Row]:
    import bench_stages as bs

    rows = bs.bench_em(repeats) + bs.bench_stereo(repeats, stereo_seq) + bs.bench_kalman(
        repeats) + bs.bench_ik(repeats)
    rows += bs.bench_loops(max(3, repeats // 2) if not quick else 1,
                           duration=2.0 if quick else 4.0)
    return rows


def peer_rows(repeats: int, stereo_seq) -> tuple[list[Peer], dict]:
    import bench_stages as bs
    import peers_camshift
    import peers_kalman
    import peers_zncc

    peers = peers_kalman.bench_kalman_peers(repeats)
    peers += peers_zncc.bench_zncc_peers(repeats, stereo_seq)
    lut, _ = bs.skin_lut()
    cam_peers, accuracy = peers_camshift.bench_camshift_peers(repeats, lut)
    return peers + cam_peers, accuracy


def print_table(console: Console, rows: list[Row], peers: list[Peer], title: str) -> None:
    table = Table(title=title)
    for col, just in (("#", "right"), ("benchmark", "left"), ("median", "right"),
                      ("IQR", "right"), ("unit", "left"), ("n", "right"),
                      ("ours/peer", "right")):
        table.add_column(col, justify=just)
    notes: list[str] = []

    def add(r: Row, ratio: str = "", note: str = "", end: bool = False) -> None:
        text = note or r.note
        ref = ""
        if text:
            notes.append(text)
            ref = str(len(notes))
        spread = "-" if r.skipped else f"{fmt(r.q1)}-{fmt(r.q3)}"
        table.add_row(ref, r.name, fmt(r.median) if not r.skipped else "skipped", spread,
                      r.unit, str(r.repeats or "-"), ratio, end_section=end)

    groups = list(dict.fromkeys(r.group for r in rows))
    for g in groups:
        rs = [r for r in rows if r.group == g]
        for i, r in enumerate(rs):
            add(r, end=i == len(rs) - 1)
    for p in peers:
        add(p.ours)
        add(p.peer, f"{p.ratio:.2f}x" if p.ratio is not None else "-", p.note, end=True)
    console.print(table)
    for i, n in enumerate(notes, 1):
        console.print(f"[dim]{i:>2}.[/dim] {n}", highlight=False)


def tracker_main(bench, title: str, doc: str, argv: list[str] | None = None) -> int:
    """The command line of a per-tracker benchmark (``bench(repeats, clock) -> rows``): repeats,
    ``--quick``, ``--clock``; prints the rows as one table."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="3 repeats")
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                    help="cpu: process CPU time (a shared, loaded machine)")
    args = ap.parse_args(argv)
    print_table(Console(), bench(3 if args.quick else args.repeats, args.clock), [], title)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=7, help="repeats per benchmark (default 7)")
    ap.add_argument("--quick", action="store_true", help="3 repeats, short loops (a smoke test)")
    ap.add_argument("--json", type=Path, default=DEFAULT_JSON)
    ap.add_argument("--only", nargs="+", choices=GROUPS, default=list(GROUPS))
    args = ap.parse_args(argv)
    repeats = 3 if args.quick else args.repeats
    console = Console()
    info = {"date": dt.datetime.now().isoformat(timespec="seconds"), "machine": machine(),
            "repeats": repeats, "load_average_before": os.getloadavg()}
    t0 = time.perf_counter()
    rows: list[Row] = []
    peers: list[Peer] = []
    accuracy: dict = {}
    stereo_seq = None
    if {"stages", "peers"} & set(args.only):
        from _frames import WAVE, render_sequence

        console.print("rendering the stereo wave sequence ...")
        stereo_seq = render_sequence("wave", WAVE, 3.0, cameras="stereo")
    if "world" in args.only:
        console.print("world: physics, rendering, world loop ...")
        rows += world_rows(repeats)
    if "stages" in args.only:
        console.print("stages: EM, stereo, Kalman, IK, loops ...")
        rows += stage_rows(repeats, args.quick, stereo_seq)
    if "peers" in args.only:
        console.print("peers: Kalman, ZNCC, CamShift ...")
        peers, accuracy = peer_rows(repeats, stereo_seq)
    info["load_average_after"] = os.getloadavg()
    info["wall_time_s"] = time.perf_counter() - t0
    m = info["machine"]
    title = (f"humimic benchmarks {info['date'][:10]}: {m['cpu']}, {m['cores']} cores; "
             f"median and IQR over {repeats} repeats; load avg "
             f"{info['load_average_before'][0]:.1f} -> {info['load_average_after'][0]:.1f}")
    print_table(console, rows, peers, title)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({**info, "rows": [r.as_dict() for r in rows],
                                     "peers": [p.as_dict() for p in peers],
                                     "tracker_accuracy": accuracy}, indent=2, default=float))
    console.print(f"wrote {args.json} ({info['wall_time_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
