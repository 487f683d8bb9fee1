"""One page per run: ``python -m humimic.report RUN_DIR`` writes ``report.png`` and
``report.html`` (also written at the end of every run that makes plots)."""

from humimic.report.page import NotARunError, write_report

__all__ = ["NotARunError", "write_report"]
