"""Run a sweep: ``python -m humimic.sweep SWEEP.yaml [--out DIR] [--jobs N] [--backend local|ray]
[--address ADDR] [--dry-run] [--force] [--quiet]``.

Every run is one ``humimic.run.run_one`` call into ``DIR/<run-name>/``; rerunning the command
skips complete runs. A bad sweep file (or an override the scenario does not accept) prints one
line naming the file, the line and the dotted key, and exits with status 2 before anything
runs. Exit status 1 when some runs failed (they are listed in the summary), 0 otherwise.
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse
import sys
from pathlib import Path

from rich.console import Console

from humimic.errors import InputError, report_error
from humimic.sweep.backends import BACKENDS


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m humimic.sweep",
        description="Run every run of a sweep file (grid x list x seeds) with the same "
                    "run_one as python -m humimic.run; complete runs are skipped.",
        epilog="Exit status: 0 all runs ok, 1 some runs failed (see summary.md), 2 bad input.")
    p.add_argument("sweep", type=Path, help="sweep YAML file (see sweeps/)")
    p.add_argument("--out", type=Path, default=None,
                   help="output directory (default: runs/sweeps/<sweep name>)")
    p.add_argument("--jobs", type=int, default=None,
                   help="parallel runs (default: the CPUs available); 1 runs in this process")
    p.add_argument("--backend", choices=BACKENDS, default="local",
                   help="local processes (joblib/loky) or Ray (pip install 'humimic[cluster]')")
    p.add_argument("--address", default=None,
                   help="Ray cluster address (default: $RAY_ADDRESS, else a local Ray)")
    p.add_argument("--dry-run", action="store_true",
                   help="validate every run and list them; run nothing")
    p.add_argument("--force", action="store_true", help="rerun complete runs too")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    console = Console()
    if args.jobs is not None and args.jobs < 1:
        return report_error(f"--jobs must be >= 1, got {args.jobs}")
    from humimic.sweep.config import load_sweep
    from humimic.sweep.driver import default_out_dir, run_sweep
    from humimic.sweep.plan import plan_sweep

    try:
        sweep = load_sweep(args.sweep)
        if args.dry_run:
            out = args.out or default_out_dir(sweep)
            planned = plan_sweep(sweep, out)
            for p in planned:
                console.print(f"{p.out_dir}  seed={p.spec.seed}  "
                              f"{ {o.key: o.value for o in p.spec.overrides} }")
            console.print(f"{len(planned)} runs, all scenarios valid")
            return 0
        result = run_sweep(sweep, args.out, args.jobs, args.backend, args.address,
                           force=args.force, progress=not args.quiet, console=console)
    except InputError as err:
        return report_error(err)
    except KeyboardInterrupt:
        print("interrupted: the summary lists the runs done so far; run the same command "
              "again to resume", file=sys.stderr)
        return 130
    return 1 if result.failed else 0


if __name__ == "__main__":
    sys.exit(main())
