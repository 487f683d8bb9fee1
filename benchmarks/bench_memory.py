"""Peak memory against simulated duration: does a long closed-loop run stay flat?

Runs ``scenarios/mimic_tracked_wave.yaml`` (stereo colour blobs, Kalman filter, mimicry; default
rates, rerun recording and plots as the scenario has them) once per duration, each in a fresh
subprocess, and prints its peak resident set size (``ru_maxrss`` of the run's own process, and
separately of its child processes, the perception worker), where the run was when its resident
set was largest (sampled every 0.2 s: the innermost humimic frames of the main thread), and
the slope in MB per simulated minute fitted over the durations. The issue's goal: a 10-minute
run within 15 % of a 5-second one.

    python benchmarks/bench_memory.py                   # 5 s, 60 s, 120 s
    python benchmarks/bench_memory.py --durations 5 600 # the goal itself (~10 min of wall time)
    python benchmarks/bench_memory.py --set 'output.rerun="off"'   # without the recording
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "mimic_tracked_wave.yaml"

_CHILD = """
import json, os, resource, sys, threading, time, traceback
from humimic.run import main

PAGE, MAIN = os.sysconf("SC_PAGE_SIZE"), threading.get_ident()
peak = {"mb": 0.0, "where": []}

def sample():  # where the run is when its resident set is largest
    while True:
        with open("/proc/self/statm") as f:
            mb = int(f.read().split()[1]) * PAGE / 2**20
        if mb > peak["mb"]:
            frames = traceback.extract_stack(sys._current_frames()[MAIN])
            peak.update(mb=mb, where=[f"{os.path.basename(f.filename)}:{f.lineno} {f.name}"
                                      for f in frames if "humimic" in f.filename][-3:])
        time.sleep(0.2)

threading.Thread(target=sample, daemon=True).start()
args = [sys.argv[1], "--duration", sys.argv[2], "--out", sys.argv[3], "--quiet"]
code = main(args + [a for o in sys.argv[4:] for a in ("--set", o)])
print(json.dumps({"code": code,
                  "self_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "children_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
                  "peak_at": " < ".join(reversed(peak["where"]))}))
"""


def peak_rss(duration: float, scenario: Path = SCENARIO, overrides: tuple[str, ...] = ()
             ) -> dict:
    """Peak RSS (MiB) of one run of ``scenario`` for ``duration`` simulated seconds."""
    with tempfile.TemporaryDirectory() as out:
        proc = subprocess.run([sys.executable, "-c", _CHILD, str(scenario), str(duration),
                               str(Path(out) / "run"), *overrides], capture_output=True,
                              text=True, check=True)
        result = json.loads(proc.stdout.strip().splitlines()[-1])
        metrics = json.loads((Path(out) / "run" / "metrics.json").read_text())
    result.update(duration_s=duration, wall_s=metrics["wall_time_s"])
    return result


def slope_mb_per_min(rows: list[dict]) -> float:
    """Least-squares slope of the run's peak RSS against duration (MiB per simulated minute)."""
    import numpy as np

    d = np.array([r["duration_s"] for r in rows]) / 60.0
    m = np.array([r["self_mb"] for r in rows])
    return float(np.polyfit(d, m, 1)[0]) if len(set(d)) > 1 else float("nan")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--durations", type=float, nargs="+", default=[5.0, 60.0, 120.0])
    p.add_argument("--set", dest="overrides", action="append", default=[],
                   metavar="KEY=VALUE", help="scenario override, as humimic.run's --set")
    p.add_argument("--json", type=Path, default=None, help="also write the rows here")
    args = p.parse_args(argv)
    rows = []
    print(f"{'sim s':>7} {'wall s':>7} {'peak MiB':>9} {'worker MiB':>10}  peak reached in")
    for duration in args.durations:
        r = peak_rss(duration, overrides=tuple(args.overrides))
        rows.append(r)
        print(f"{duration:7.0f} {r['wall_s']:7.1f} {r['self_mb']:9.1f} {r['children_mb']:10.1f}  "
              f"{r['peak_at']}", flush=True)
    slope = slope_mb_per_min(rows)
    if math.isnan(slope):   # one duration (repeated or not): peaks only, nothing to fit
        print(f"peak {min(r['self_mb'] for r in rows):.1f}-{max(r['self_mb'] for r in rows):.1f}"
              " MiB; give two or more different durations for the slope")
        return
    base = rows[0]["self_mb"]
    at_10 = base + slope * (600.0 - rows[0]["duration_s"]) / 60.0
    print(f"slope {slope:.2f} MiB per simulated minute; a 10-minute run extrapolates to "
          f"{at_10:.0f} MiB, {100 * (at_10 / base - 1):+.1f} % over the {rows[0]['duration_s']:.0f}"
          f"-s run (goal: within 15 %)")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "slope_mb_per_min": slope}, indent=2))


if __name__ == "__main__":
    main()
