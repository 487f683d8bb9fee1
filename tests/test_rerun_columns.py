"""Points and arrows at every row of a run, sent as columns, land in the .rrd as the per-row
``log`` calls they replace would: the same components, values and times (read back with
rerun's own reader; the reference is the SDK's ``log`` of each row)."""

from __future__ import annotations

import numpy as np
import pytest
from rerun.chunk import RrdReader

from humimic.viz import rerun_columns
from humimic.viz.rerun_log import RerunLog

ROWS = 50
LABELS = ["head", "right_hand", "c", "dd"]


def _columns_of(path) -> dict[tuple[str, str], list]:
    """``(entity, column) -> values`` of every temporal row under ``/world/t*`` (row ids,
    unique per call, left out)."""
    out: dict[tuple[str, str], list] = {}
    for chunk in RrdReader(path).stream():
        if chunk.entity_path.startswith("/world/t") and not chunk.is_static:
            rb = chunk.to_record_batch()
            for name in rb.schema.names:
                if "RowId" not in name:
                    out.setdefault((chunk.entity_path, name), []).extend(
                        rb.column(name).to_pylist())
    return out


def _record(path, scene, columns: bool):
    rng = np.random.default_rng(7)
    t = np.arange(ROWS) / 30.0  # times whose nanoseconds need rounding, as set_time does
    p = rng.normal(size=(ROWS, 4, 3))
    p[:3] = np.nan  # rows before a command exists
    origins, vectors = rng.normal(size=(ROWS, 2, 3)), rng.normal(size=(ROWS, 2, 3))
    magenta = [[255, 0, 255], [255, 0, 255]]
    with RerunLog(scene, "save", path, recording_id="columns") as rlog:
        if columns:
            rlog.log_points_rows("world/tp", t, p, colors=[40, 200, 40], radii=0.01,
                                 labels=LABELS)
            rlog.log_points_rows("world/tq", t, p[:, :1], colors=[0, 200, 255], radii=0.015)
            rlog.log_arrows_rows("world/tg", t, origins, vectors, colors=magenta)
        else:
            for i, ti in enumerate(t):
                rlog.log_points(ti, "world/tp", p[i], colors=[40, 200, 40], radii=0.01,
                                labels=LABELS)
                rlog.log_points(ti, "world/tq", p[i, :1], colors=[0, 200, 255], radii=0.015)
                rlog.log_arrow(ti, "world/tg", origins[i], vectors[i], colors=magenta)
    return _columns_of(path)


@pytest.fixture(scope="module")
def scene():
    from humimic.world.scene import SceneOptions, build_scene

    return build_scene(SceneOptions())


def test_rows_sent_as_columns_equal_one_log_call_per_row(scene, tmp_path, monkeypatch):
    monkeypatch.setattr(rerun_columns, "COLUMN_BYTES", 200)  # several chunks per entity
    reference = _record(tmp_path / "rows.rrd", scene, columns=False)
    sent = _record(tmp_path / "columns.rrd", scene, columns=True)
    assert {e for e, _ in reference} == {"/world/tp", "/world/tq", "/world/tg"}
    assert sorted(sent) == sorted(reference)
    for key, values in reference.items():
        assert len(values) == ROWS, key
        assert repr(sent[key]) == repr(values), key  # NaN == NaN in repr
