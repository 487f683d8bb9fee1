"""Whole-run series sent to rerun as columns, in bounded chunks (the end-of-run logging).

:class:`ColumnLog` is the part of :class:`~humimic.viz.rerun_log.RerunLog` that sends many
timestamps at once with ``send_columns``: scalar series, and points or arrows at every row of
a run (the 3-D view's mimicry and ground-truth trails). A ten-minute run has 18 000 rows at
30 Hz: sent one ``log`` call per row, each row is a chunk of its own in the SDK's batcher (a
few kB each, whatever its payload), and the SDK held them faster than it wrote them (measured:
the 600-s run peaked there). Sent as columns of at most :data:`SERIES_CHUNK` rows and
:data:`COLUMN_BYTES` of payload, each chunk is one chunk in the SDK, and
:meth:`~humimic.viz.rerun_log.RerunLog._sent` waits for the SDK past a backlog. A row of a
column holds what one ``log`` call of that row would: the same components, the same values.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from humimic.viz.entities import TIMELINE

#: Rows of a series sent as one chunk (scalar series: 32 768 x a few floats).
SERIES_CHUNK = 1 << 15
#: Payload (bytes, estimated) of one chunk of a points or arrows column.
COLUMN_BYTES = 1 << 20


def _rows_per_chunk(bytes_per_row: int) -> int:
    return int(max(1, min(SERIES_CHUNK, COLUMN_BYTES // max(1, bytes_per_row))))


def _per_row(value, n_rows: int, width: int) -> np.ndarray | None:
    """A per-call component (one value, or one per instance) repeated for ``n_rows`` rows,
    flattened to ``(n_rows * k, width)``; ``k`` is how many values one call had."""
    if value is None:
        return None
    v = np.asarray(value).reshape(-1, width)
    return np.tile(v, (n_rows, 1))


class ColumnLog:
    """Column-wise logging; mixed into ``RerunLog`` (needs ``_rec``, ``_sent`` and ``logged``)."""

    _rec: rr.RecordingStream | None
    logged: set[str]

    def log_series(self, entity: str, times: np.ndarray, values: np.ndarray,
                   names: list[str] | None = None, colors=None, widths=None) -> None:
        """A whole series in one call: ``values`` (N,) or (N, k) at ``times`` (N,) in s; one
        legend name (with its unit) per line, optionally colours and widths."""
        if self._rec is None or len(times) == 0:
            return
        self.logged.add(entity)
        v = np.asarray(values, dtype=float)
        v, times = (v if v.ndim == 2 else v.reshape(-1, 1)), np.asarray(times, dtype=float)
        for k in range(0, len(times), SERIES_CHUNK):  # bounded chunks: bounded SDK buffers
            self._rec.send_columns(
                entity, indexes=[rr.TimeColumn(TIMELINE, duration=times[k:k + SERIES_CHUNK])],
                columns=rr.Scalars.columns(scalars=v[k:k + SERIES_CHUNK]))
            self._sent(v[k:k + SERIES_CHUNK].nbytes + 8 * len(times[k:k + SERIES_CHUNK]))
        if names is not None:
            self.set_series_names(entity, names, colors, widths)

    def set_series_names(self, entity: str, names: list[str], colors=None,
                         widths=None) -> None:
        """Legend names (and colours, widths) of the lines of a scalar entity (static)."""
        if self._rec is not None:
            self._rec.log(entity, rr.SeriesLines(names=list(names), colors=colors,
                                                 widths=widths), static=True)

    def log_points_rows(self, entity: str, times: np.ndarray, points: np.ndarray, colors=None,
                        radii=0.012, labels=None, show_labels: bool = False) -> None:
        """Points at every row: ``points`` (N, M, 3) at ``times`` (N,) in s, each row as
        :meth:`~humimic.viz.rerun_log.RerunLog.log_points` at its time would log it (the same
        ``colors``, ``radii``, ``labels`` and ``show_labels`` in every row)."""
        if self._rec is None or len(times) == 0:
            return
        times = np.asarray(times, dtype=float)
        points = np.asarray(points, dtype=float).reshape(len(times), -1, 3)
        m = points.shape[1]
        labels = None if labels is None else list(labels)
        row_bytes = 12 * m + 16 * len(labels or ())
        step = _rows_per_chunk(row_bytes)
        for k in range(0, len(times), step):
            n = len(times[k:k + step])
            cols = rr.Points3D.columns(
                positions=points[k:k + n].reshape(-1, 3),
                colors=_per_row(colors, n, np.asarray(colors).shape[-1]) if colors is not None
                else None,
                radii=_per_row(radii, n, 1)[:, 0] if radii is not None else None,
                labels=None if labels is None else labels * n,
                show_labels=np.full(n, show_labels))
            self._send_rows(entity, times[k:k + n], cols, n, {
                "positions": m, "colors": _count(colors), "radii": _count(radii),
                "labels": len(labels or ()), "show_labels": 1})
            self._sent(n * row_bytes)

    def log_arrows_rows(self, entity: str, times: np.ndarray, origins: np.ndarray,
                        vectors: np.ndarray, colors=None) -> None:
        """Arrows at every row: ``origins`` and ``vectors`` (N, M, 3) at ``times`` (N,) in s,
        each row as :meth:`~humimic.viz.rerun_log.RerunLog.log_arrow` would log it."""
        if self._rec is None or len(times) == 0:
            return
        times = np.asarray(times, dtype=float)
        origins = np.asarray(origins, dtype=float).reshape(len(times), -1, 3)
        vectors = np.asarray(vectors, dtype=float).reshape(len(times), -1, 3)
        m = vectors.shape[1]
        step = _rows_per_chunk(24 * m)
        for k in range(0, len(times), step):
            n = len(times[k:k + step])
            cols = rr.Arrows3D.columns(
                origins=origins[k:k + n].reshape(-1, 3), vectors=vectors[k:k + n].reshape(-1, 3),
                colors=_per_row(colors, n, np.asarray(colors).shape[-1]) if colors is not None
                else None)
            self._send_rows(entity, times[k:k + n], cols, n, {
                "origins": origins.shape[1], "vectors": m, "colors": _count(colors)})
            self._sent(n * 24 * m)

    def _send_rows(self, entity: str, times: np.ndarray, cols, n: int,
                   per_row: dict[str, int]) -> None:
        """Send ``cols`` as ``n`` rows: each component's column cut into rows of its
        ``per_row`` values (a row of a ``log`` call)."""
        parts = []
        for col in cols:
            field = col.descriptor.component.split(":")[-1]
            parts.append(col.partition(np.full(n, per_row[field], dtype=np.int32)))
        self._rec.send_columns(entity, indexes=[rr.TimeColumn(TIMELINE, duration=_nanos(times))],
                               columns=parts)


def _nanos(times_s: np.ndarray) -> np.ndarray:
    """Times in s as the nanoseconds ``set_time(duration=t)`` gives (rounded to the nearest;
    ``TimeColumn`` of float seconds truncates)."""
    return np.rint(1e9 * np.asarray(times_s, dtype=float)).astype(np.int64).astype(
        "timedelta64[ns]")


def _count(value) -> int:
    """Values one call passes for a component: 1 for a scalar or one colour, else its rows."""
    if value is None:
        return 0
    v = np.asarray(value)
    return 1 if v.ndim <= 1 else len(v)
