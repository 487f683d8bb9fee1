"""The recording's memory stays bounded when a long run logs its end-of-run series: the SDK
encodes and writes on its own threads, so :class:`~humimic.viz.rerun_log.RerunLog` hands it
bounded chunks and waits for it past a backlog. Peak RSS measured in a child process; the
series read back whole with rerun's own reader."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from rerun.chunk import RrdReader

ROWS, SERIES = 250_000, 12  # ten minutes at the 420 Hz servo rate; 12 joints
_CHILD = f"""
import json, sys
import numpy as np
from humimic import select_gl_backend
select_gl_backend()
from humimic.viz.rerun_log import RerunLog
from humimic.world.scene import SceneOptions, build_scene

def hwm():
    return [int(l.split()[1]) / 1024 for l in open("/proc/self/status") if l.startswith("VmHWM")][0]

with RerunLog(build_scene(SceneOptions()), "save", sys.argv[1], recording_id="mem") as rlog:
    rlog.log_series("series/warmup", np.arange(10.0), np.zeros(10))  # the SDK's own threads
    rlog._rec.flush()
    h0 = hwm()
    t = np.arange({ROWS}) / 420.0
    for j in range({SERIES}):
        rlog.log_series(f"series/j{{j}}", t, np.full((len(t), 2), float(j)))
    grown = hwm() - h0
print(json.dumps(grown))
"""


def test_long_series_do_not_pile_up_in_the_sdk(tmp_path):
    """12 series of 250 000 rows x 2 (48 MB of values): +31 MiB of peak RSS measured (168 MiB
    when each is sent whole without waiting for the SDK); the bound is 80 MiB."""
    path = tmp_path / "long.rrd"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1] / "src"))
    out = subprocess.run([sys.executable, "-c", _CHILD, str(path)], capture_output=True,
                         text=True, check=True, env=env)
    grown = json.loads(out.stdout.strip().splitlines()[-1])
    assert grown < 80.0
    rows = 0
    for chunk in RrdReader(path).stream():  # every row arrived, in its chunks
        if chunk.entity_path == "/series/j7" and not chunk.is_static:
            rb = chunk.to_record_batch()
            rows += rb.num_rows
            assert np.all(np.array(rb.column("Scalars:scalars").to_pylist()) == 7.0)
    assert rows == ROWS
