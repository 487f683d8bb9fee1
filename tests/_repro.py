"""Same seed, same bits across processes: run a snippet in two fresh Python processes, the
second under other conditions -- another hash seed (dict/set order), OpenBLAS and OpenCV on
one thread (reduction orders that depend on the thread count), a perturbed heap (results that
depend on an array's address or alignment) -- and return what each printed. The snippet runs
after :data:`PREAMBLE`, with the tests' helpers and the package importable, and calls
``shift_heap()`` between its steps (in the perturbed process: allocations that move the next
ones' addresses)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

PREAMBLE = textwrap.dedent("""
    import os
    PERTURB = bool(os.environ.get("REPRO_PERTURB"))
    if PERTURB:
        import cv2
        cv2.setNumThreads(1)
    import numpy as np
    _keep = []

    def shift_heap():
        if PERTURB and not _keep:
            _keep.extend([np.empty(k) for k in range(1, 40, 3)]
                         + [bytearray(k) for k in range(1, 99, 7)])
        _keep.append(np.empty(len(_keep) % 7 + 1))
""")


def run_child(body: str, perturb: bool) -> str:
    """``body`` (dedented) run after :data:`PREAMBLE` in a fresh process; its stdout."""
    tests = Path(__file__).resolve().parent
    src = tests.parent / "src"
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(tests), str(src), env.get("PYTHONPATH", "")])
    env["PYTHONHASHSEED"] = "1" if perturb else "2"
    if perturb:
        env.update(REPRO_PERTURB="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", PREAMBLE + textwrap.dedent(body)], env=env,
                         capture_output=True, text=True, timeout=600, check=False)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def outputs_in_two_processes(body: str) -> tuple[str, str]:
    """What ``body`` prints in a plain process and in a perturbed one."""
    return run_child(body, False), run_child(body, True)
