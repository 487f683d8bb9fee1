"""A run's tracking records as one ``.npz`` file (``tracking.npz`` next to ``metrics.json``).

What perception measured and the filter estimated per frame, plus the ground truth at the
frames' photon times, so scores and the paper's reproductions can be recomputed off-line
(``python -m humimic.perception.reproduce``) without re-running the simulation. With the eyes'
visibility ground truth (:mod:`humimic.sensors.visibility`), its samples too (``vis_*``: sample
times, target pixels seen and whole silhouettes per eye camera and target, from which in view,
unoccluded fraction and size in pixels follow).

:func:`read_rows` reads one array of the file a block of rows at a time, keeping only what a
caller takes from each block (a target's column): a long run's report reads its series without
the whole archive in memory; :func:`save_archive` writes a record's columns straight from
its spilled rows, a batch at a time (:func:`write_npz`), never stacking the whole record.
"""

from __future__ import annotations

import itertools
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from humimic.estimation.stage import FilterArrays, FilterRecord
from humimic.perception.blobs.record import PerceptionArrays, PerceptionRecord
from humimic.sensors.camera_model import Intrinsics
from humimic.sensors.visibility import VisibilityArrays
from humimic.spill import read_blocks

_INTR = ("width", "height", "fx", "fy", "cx", "cy", "k1", "k2")


@dataclass
class TrackingArchive:
    perception: PerceptionArrays
    filter: FilterArrays | None
    truth: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
    """Published target -> true (p, v, a) at the perception frames, base frame, (F, 3) each."""
    filter_truth: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
    """The same at the filter's frames (a pipelined perception's last frame may be missing)."""
    visibility: VisibilityArrays | None = None
    """The eyes' visibility ground truth (None: the run sampled none)."""


def save_archive(path: str | Path, pa: PerceptionArrays | PerceptionRecord,
                 fa: FilterArrays | FilterRecord | None,
                 truth: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
                 filter_truth: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
                 visibility: VisibilityArrays | None = None) -> Path:
    """Write the archive; ``pa``/``fa`` are stacked arrays or the records themselves (whose
    per-frame columns are then streamed from their spilled rows, see :func:`write_npz`)."""
    path = Path(path)
    data: dict[str, np.ndarray | Blocks] = {
        "targets": np.array(pa.targets), "cameras": np.array(pa.cameras),
        "truth_targets": np.array(list(truth)),
        "intrinsics": np.array([[getattr(i, k) for k in _INTR] for i in pa.intrinsics]
                               if pa.intrinsics is not None else np.zeros((0, 8)), float),
    }
    data.update(_columns(pa, PerceptionArrays, "p_", ("targets", "cameras", "intrinsics")))
    if fa is not None:
        data["f_targets"] = np.array(fa.targets)
        data.update(_columns(fa, FilterArrays, "f_", ("targets",)))
    for target, (p, v, a) in truth.items():
        data[f"truth_{target}"] = np.stack([p, v, a])
    for target, (p, v, a) in filter_truth.items():
        data[f"ftruth_{target}"] = np.stack([p, v, a])
    if visibility is not None:
        data.update(vis_cameras=np.array(visibility.cameras), vis_targets=np.array(
            visibility.targets), vis_t=visibility.t, vis_visible_px=visibility.visible_px,
            vis_full_px=visibility.full_px)
    return write_npz(path, data)


def _columns(source, cls, prefix: str, meta: tuple[str, ...]) -> dict:
    """``prefix + field`` -> the per-frame field of ``cls`` (arrays), from ``source``: the
    stacked arrays, or a record whose rows hold the fields in the dataclass's order (each
    column then a :class:`Blocks` of its batches; the strings of ``reason`` stacked whole)."""
    names = [f.name for f in fields(cls) if f.name not in meta]
    if not isinstance(source, cls) and not len(source.rows):
        source = source.arrays()
    if isinstance(source, cls):
        return {prefix + name: getattr(source, name).astype(str) if name == "reason"
                else getattr(source, name) for name in names}
    numeric = [j for j, name in enumerate(names) if name != "reason"]
    files = dict(zip(numeric, source.rows.column_files(numeric), strict=True))  # one pass
    out = {}
    for j, name in enumerate(names):
        if name == "reason":
            out[prefix + name] = source.rows.columns({j: lambda c: c})[0].astype(str)
        else:
            out[prefix + name] = Blocks(files[j].n, files[j].blocks,
                                        float if name == "t" else None)
    return out


@dataclass
class Blocks:
    """An ``(n, ...)`` array given as consecutive blocks of rows (``blocks()`` iterates them),
    written by :func:`write_npz` as they come; ``dtype`` None: the first block's."""

    n: int
    blocks: Callable
    dtype: object = None


def write_npz(path: str | Path, data: dict[str, np.ndarray | Blocks]) -> Path:
    """``np.savez_compressed(path, **data)`` (the same file format), where a :class:`Blocks`
    entry is written a block at a time: memory holds one block of it, not the array."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
        for key, value in data.items():
            with zf.open(f"{key}.npy", "w", force_zip64=True) as f:
                if not isinstance(value, Blocks):
                    np.lib.format.write_array(f, np.asanyarray(value), allow_pickle=False)
                    continue
                rows, written = iter(value.blocks()), 0
                first = next(rows)
                dtype = np.dtype(value.dtype or first.dtype)
                np.lib.format.write_array_header_1_0(f, {
                    "descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False,
                    "shape": (value.n, *first.shape[1:])})
                for block in itertools.chain([first], rows):
                    f.write(np.ascontiguousarray(block, dtype).tobytes())
                    written += len(block)
                if written != value.n:
                    raise ValueError(f"{key}: {written} rows written, {value.n} announced")
    return Path(path)


def load_archive(path: str | Path) -> TrackingArchive:
    with np.load(path, allow_pickle=False) as z:
        intr = tuple(Intrinsics(int(r[0]), int(r[1]), *map(float, r[2:]))
                     for r in z["intrinsics"]) or None
        kw = {f.name: z[f"p_{f.name}"] for f in fields(PerceptionArrays)
              if f.name not in ("targets", "cameras", "intrinsics")}
        kw["reason"] = kw["reason"].astype(object)
        pa = PerceptionArrays(targets=[str(x) for x in z["targets"]],
                              cameras=tuple(str(x) for x in z["cameras"]), intrinsics=intr, **kw)
        fa = None
        if "f_targets" in z.files:
            fa = FilterArrays(targets=[str(x) for x in z["f_targets"]],
                              **{f.name: z[f"f_{f.name}"] for f in fields(FilterArrays)
                                 if f.name != "targets"})
        truth = {str(t): tuple(z[f"truth_{t}"]) for t in z["truth_targets"]}
        ftruth = {str(t): tuple(z[f"ftruth_{t}"]) for t in z["truth_targets"]
                  if f"ftruth_{t}" in z.files}
        vis = None
        if "vis_t" in z.files:
            vis = VisibilityArrays([str(c) for c in z["vis_cameras"]],
                                   [str(t) for t in z["vis_targets"]], z["vis_t"],
                                   z["vis_visible_px"], z["vis_full_px"])
    return TrackingArchive(pa, fa, truth, ftruth, vis)


#: Rows of an archived array read per step by :func:`read_rows`.
READ_BLOCK = 4096


def read_rows(path: str | Path, key: str,
              take: Callable[[np.ndarray], np.ndarray] = lambda rows: rows) -> np.ndarray:
    """``take(a)`` of the array ``key`` of the ``.npz`` at ``path``, where ``take`` works row by
    row (selects along the later axes, e.g. ``lambda a: a[:, i, :3]``): computed on
    :data:`READ_BLOCK` rows at a time streamed from the file and concatenated, so memory holds
    the result and one block, not the array."""
    with zipfile.ZipFile(path) as zf, zf.open(f"{key}.npy") as f:
        version = np.lib.format.read_magic(f)
        header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                  else np.lib.format.read_array_header_2_0)
        shape, fortran, dtype = header(f)
        if fortran or dtype.hasobject or not shape:  # not row-major: load it whole
            with np.load(path, allow_pickle=False) as z:
                return take(z[key])
        parts = [take(np.empty((0, *shape[1:]), dtype))]
        parts += [np.array(take(block))
                  for block in read_blocks(f, shape[0], dtype, shape[1:], READ_BLOCK)]
    return np.concatenate(parts)
