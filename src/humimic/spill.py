"""Per-tick records that live on disk: memory stays flat however long the run.

A :class:`SpillArray` has the shape ``(n, *tail)`` of a preallocated numpy array and is
written the same way, row by row as the run advances (``a[k] = row``, ``a[k, i] = value``), but
only a window of :data:`BLOCK` rows is in memory; when a write moves past the window, the window
is appended to an unnamed temporary file. Reading (``a[k0:n, i]``, ``a[:n]``, ``a[k]``) gathers
just the requested entries block by block, so a column of a long run costs the column's size,
not the record's. Rows never written read as ``fill``.
"""

from __future__ import annotations

import pickle
import tempfile

import numpy as np

#: Rows of a :class:`SpillArray` held in memory (and read back per step).
BLOCK = 4096
#: Rows of a :class:`SpillRows` held in memory (per-frame rows are larger: a few kB each).
BATCH = 256


class SpillArray:
    """``(n, *tail)`` array whose rows before the write window are on disk (see module doc)."""

    def __init__(self, n: int, tail: tuple[int, ...] = (), dtype=float, fill=0.0):
        self.shape = (int(n), *tail)
        self.dtype = np.dtype(dtype)
        self.fill = fill
        self._window = np.full((BLOCK, *tail), fill, self.dtype)
        self._base = 0  # row index of the window's first row (rows before it are in the file)
        self._file = None

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def __len__(self) -> int:
        return self.shape[0]

    # ---- writing ---------------------------------------------------------------------------
    def _row(self, k) -> int:
        k = int(k)
        if not 0 <= k < self.shape[0]:
            raise IndexError(f"row {k} outside 0..{self.shape[0] - 1}")
        if k < self._base:
            raise IndexError(f"row {k} is already on disk (rows are written in order)")
        while k >= self._base + BLOCK:
            if self._file is None:
                self._file = tempfile.TemporaryFile()
            self._file.seek(0, 2)
            self._file.write(self._window.tobytes())
            self._window.fill(self.fill)
            self._base += BLOCK
        return k - self._base

    def __setitem__(self, key, value) -> None:
        if isinstance(key, tuple):
            self._window[(self._row(key[0]), *key[1:])] = value
        else:
            self._window[self._row(key)] = value

    # ---- reading ---------------------------------------------------------------------------
    def _block(self, b: int) -> np.ndarray:
        """Rows ``[b, b + BLOCK)`` (the window, or read from the file)."""
        if b == self._base:
            return self._window
        tail = self.shape[1:]
        if b > self._base:  # never written
            return np.full((BLOCK, *tail), self.fill, self.dtype)
        row_bytes = self.dtype.itemsize * int(np.prod(tail, dtype=int))
        self._file.seek(b * row_bytes)
        return np.frombuffer(self._file.read(BLOCK * row_bytes), self.dtype).reshape(BLOCK, *tail)

    def __getitem__(self, key):
        first, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        if isinstance(first, (int, np.integer)):
            k = int(first) + (self.shape[0] if first < 0 else 0)
            if not 0 <= k < self.shape[0]:
                raise IndexError(f"row {first} outside 0..{self.shape[0] - 1}")
            b = k // BLOCK * BLOCK
            return np.array(self._block(b)[(k - b, *rest)])
        if not isinstance(first, slice) or (first.step or 1) < 0:  # an index array: numpy's
            rows = np.arange(self.shape[0])[first]  # rules, rows gathered one block at a time
            out = [self._block(b)[(rows[rows // BLOCK * BLOCK == b] - b, *rest)]
                   for b in np.unique(rows // BLOCK * BLOCK).tolist()]
            order = np.argsort(np.argsort(rows // BLOCK, kind="stable"), kind="stable")
            probe = np.empty((0, *self.shape[1:]), self.dtype)[(np.zeros(0, int), *rest)]
            return np.concatenate(out)[order] if out else probe
        start, stop, step = first.indices(self.shape[0])
        parts = [np.empty((0, *self.shape[1:]), self.dtype)[(slice(None), *rest)]]
        k = start
        while k < stop:  # each block read once, sliced as numpy would slice the whole array
            b = k // BLOCK * BLOCK
            end = min(stop, b + BLOCK)
            parts.append(np.array(self._block(b)[(slice(k - b, end - b, step), *rest)]))
            k += -(-(end - k) // step) * step
        return np.concatenate(parts)

    def __array__(self, dtype=None, copy=None):
        out = self[:]
        return out if dtype is None else out.astype(dtype)

    def truncate(self, n: int) -> SpillArray:
        """Keep the first ``n`` rows (in place; returns ``self``)."""
        self.shape = (min(int(n), self.shape[0]), *self.shape[1:])
        return self


def row_blocks(a, start: int, stop: int):
    """Rows ``[start, stop)`` of ``a`` (a :class:`SpillArray` or an array) as consecutive
    arrays of at most :data:`BLOCK` rows, aligned to :class:`SpillArray`'s blocks: reductions
    over a long record without the whole column in memory."""
    k = start
    while k < stop:
        end = min(stop, (k // BLOCK + 1) * BLOCK)
        yield a[k:end]
        k = end


class SpillRows:
    """An append-only list of per-frame row tuples whose full batches of :data:`BATCH` rows are
    pickled to an unnamed temporary file; :meth:`columns` stacks each column batch by batch.
    Replaces a ``list`` of rows in the records that stack them after the run."""

    def __init__(self):
        self._batch: list[tuple] = []
        self._n = 0
        self._file = None

    def append(self, row: tuple) -> None:
        self._batch.append(row)
        self._n += 1
        if len(self._batch) >= BATCH:
            if self._file is None:
                self._file = tempfile.TemporaryFile()
            self._file.seek(0, 2)
            pickle.dump(self._batch, self._file, protocol=pickle.HIGHEST_PROTOCOL)
            self._batch = []

    def __len__(self) -> int:
        return self._n

    def _batches(self):
        if self._file is not None:
            self._file.seek(0)
            while True:
                try:
                    yield pickle.load(self._file)
                except EOFError:
                    break
        if self._batch:
            yield self._batch

    def __iter__(self):
        for batch in self._batches():
            yield from batch

    def column_files(self, js: list[int]) -> list[ColumnFile]:
        """Columns ``js`` each copied to its own temporary file in one pass over the rows (a
        column's rows then read back a block at a time, without unpickling them again)."""
        out = [ColumnFile(self._n) for _ in js]
        for batch in self._batches():
            for f, j in zip(out, js, strict=True):
                f.append(np.array([row[j] for row in batch]))
        return out

    def columns(self, take: dict | None = None) -> list[np.ndarray]:
        """Column ``j`` is ``np.array([row[j] for row in rows])``, built one batch at a time
        into its preallocated result (peak memory: the columns and one batch, not twice the
        columns). ``take`` (``{j: function}``) keeps only those columns, each as
        ``function(column)`` computed batch by batch: the function must work row by row
        (select along the later axes, e.g. ``lambda c: c[:, [i]]``), so only what it keeps is
        ever gathered."""
        out: list[np.ndarray] = []
        k = 0
        for batch in self._batches():
            cols = [np.array(c) for c in zip(*batch, strict=True)]
            if take is not None:
                cols = [np.asarray(f(cols[j])) for j, f in take.items()]
            if not out:
                out = [np.empty((self._n, *c.shape[1:]), c.dtype) for c in cols]
            for j, c in enumerate(cols):
                dtype = np.result_type(out[j].dtype, c.dtype)  # e.g. longer strings later
                if dtype != out[j].dtype:
                    out[j] = out[j].astype(dtype)
                out[j][k:k + len(c)] = c
            k += len(batch)
        return out


class ColumnFile:
    """One column's ``n`` rows as raw bytes in an unnamed temporary file, of the dtype and row
    shape of the first rows appended (later ones are cast to it)."""

    def __init__(self, n: int):
        self.n, self.dtype, self.tail = int(n), None, ()
        self._file = tempfile.TemporaryFile()

    def append(self, rows: np.ndarray) -> None:
        if self.dtype is None:
            self.dtype, self.tail = rows.dtype, rows.shape[1:]
        self._file.write(np.ascontiguousarray(rows, self.dtype).tobytes())

    def blocks(self):
        """The rows, :data:`BLOCK` at a time."""
        self._file.seek(0)
        yield from read_blocks(self._file, self.n, self.dtype, self.tail, BLOCK)


def read_blocks(f, n: int, dtype, tail: tuple[int, ...], block: int):
    """``n`` rows of shape ``tail`` stored raw (C order) from the file object ``f``'s position
    on, read ``block`` rows at a time (read-only arrays over the bytes read)."""
    dtype = np.dtype(dtype)
    row_bytes = dtype.itemsize * int(np.prod(tail, dtype=np.int64))
    for start in range(0, n, block):
        m = min(block, n - start)
        yield np.frombuffer(f.read(m * row_bytes), dtype).reshape(m, *tail)
