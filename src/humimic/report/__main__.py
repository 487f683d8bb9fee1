"""``python -m humimic.report RUN_DIR``: write the run's one-page report (PNG + HTML)."""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse
import sys

from humimic.errors import InputError, report_error
from humimic.report.page import write_report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m humimic.report",
                                 description="Write report.png and report.html for a run.")
    ap.add_argument("run_dir", help="a run directory (it holds metrics.json)")
    args = ap.parse_args(argv)
    try:
        png, page = write_report(args.run_dir)
    except InputError as err:
        return report_error(err)
    print(f"wrote {png} and {page}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
