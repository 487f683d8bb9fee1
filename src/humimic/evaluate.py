"""Trajectory errors of TUM-format files, as evo computes them (:mod:`humimic.maths.trajectory`).

::

    python -m humimic.evaluate ape GT.txt EST.txt --align none|se3|sim3
    python -m humimic.evaluate rpe GT.txt EST.txt --delta 10 [--align ...]

Prints the RMSE of the translation errors in metres (and how many pose pairs it is over).
Poses are associated by time stamp: nearest within ``--max-diff`` seconds (0.01 by default).
A bad file or option prints one line and exits with status 2.
"""

from __future__ import annotations

import argparse
import sys

from humimic.errors import report_error
from humimic.maths.align import ALIGNMENTS
from humimic.maths.trajectory import MAX_DIFF_S, ape, read_tum, rpe


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m humimic.evaluate",
                                description="Trajectory errors (m) of TUM-format files.")
    sub = p.add_subparsers(dest="metric", required=True)
    for name, what in (("ape", "absolute pose error (ATE), translation part"),
                       ("rpe", "relative pose error, translation part")):
        s = sub.add_parser(name, help=what, description=what)
        s.add_argument("reference", help="ground-truth TUM file")
        s.add_argument("estimate", help="estimated TUM file")
        s.add_argument("--align", choices=ALIGNMENTS, default="none",
                       help="align the estimate to the reference first (default: none)")
        s.add_argument("--max-diff", type=float, default=MAX_DIFF_S,
                       help="largest time difference of associated poses, s (default 0.01)")
        if name == "rpe":
            s.add_argument("--delta", type=int, default=1,
                           help="pose pairs this many poses apart (default 1)")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        t_ref, T_ref = read_tum(args.reference)
        t_est, T_est = read_tum(args.estimate)
        if args.metric == "ape":
            err = ape(t_ref, T_ref, t_est, T_est, args.align, args.max_diff)
        else:
            err = rpe(t_ref, T_ref, t_est, T_est, args.delta, args.align, args.max_diff)
    except (OSError, ValueError) as e:
        return report_error(e)
    scale = f", scale {err.scale:.6g}" if args.align == "sim3" else ""
    print(f"{args.metric} rmse {err.rmse_m:.6f} m ({err.pairs} pairs, align {args.align}"
          f"{scale})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
