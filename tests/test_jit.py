"""The project's numba options: compiled functions keep numpy's division semantics."""

import numpy as np

from humimic.maths.jit import njit


@njit
def _ratio(a, b):
    out = np.empty_like(a)
    for i in range(a.size):
        out[i] = a[i] / b[i]
    return out


def test_njit_divides_like_numpy():
    a = np.array([1.0, -1.0, 0.0, 2.0])
    b = np.array([0.0, 0.0, 0.0, 4.0])
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = a / b
    np.testing.assert_array_equal(_ratio(a, b), expected)


def test_cache_digest_follows_kernel_files_and_their_imports(tmp_path):
    """The numba cache's directory changes with a kernel module's source and with a humimic
    module it imports (numba's own cache sees neither a callee's nor a constant's edit in
    another file), not with an unrelated module."""
    from humimic.maths.jit import kernel_sources_digest

    pkg = tmp_path / "humimic"
    (pkg / "geo").mkdir(parents=True)
    (pkg / "geo" / "__init__.py").write_text("")
    (pkg / "geo" / "consts.py").write_text("Z_MIN = 0.05\n")
    (pkg / "kern.py").write_text("from humimic.maths.jit import njit\n"
                                 "from humimic.geo.consts import Z_MIN\n")
    (pkg / "other.py").write_text("X = 1\n")
    d0 = kernel_sources_digest(pkg)
    (pkg / "other.py").write_text("X = 2\n")
    assert kernel_sources_digest(pkg) == d0
    (pkg / "geo" / "consts.py").write_text("Z_MIN = 0.06\n")
    d1 = kernel_sources_digest(pkg)
    assert d1 != d0
    (pkg / "kern.py").write_text((pkg / "kern.py").read_text() + "# edit\n")
    assert kernel_sources_digest(pkg) not in (d0, d1)


def test_cache_location_never_falls_back_beside_the_sources(tmp_path, monkeypatch):
    """The user's NUMBA_CACHE_DIR is kept; one a humimic parent exported is replaced by this
    digest's; an unwritable humimic cache falls back to the temporary directory, and with
    nothing writable there is no cache (numba's own fallback, the source tree, goes stale)."""
    import tempfile

    from humimic.maths.jit import cache_location

    monkeypatch.setenv("HUMIMIC_CACHE_DIR", str(tmp_path / "cache"))
    assert cache_location({"NUMBA_CACHE_DIR": "/mine"}, "d1") == "/mine"
    parent = {"NUMBA_CACHE_DIR": "/old/d0", "HUMIMIC_NUMBA_CACHE_DIR": "/old/d0"}
    assert cache_location(parent, "d1") == str(tmp_path / "cache" / "numba" / "d1")
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("HUMIMIC_CACHE_DIR", str(blocker / "cache"))    # under a file: no dir
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    assert cache_location({}, "d1").startswith(str(tmp_path / "tmp" / "humimic-numba-"))
    monkeypatch.setattr(tempfile, "tempdir", str(blocker / "tmp"))
    assert cache_location({}, "d1") is None


def test_frame_cue_kernels_loaded_for_every_tracker_that_counts_colours():
    """After :func:`frame_cues.load_kernels`, the patch colour counts as TBP (a strided slice of
    its projected patches), ICU and hand2d (float32 or float64 states) call them compile
    nothing new."""
    from humimic.perception.cues import histograms
    from humimic.perception.trackers.frame_cues import load_kernels

    load_kernels(None, 16)
    loaded = len(histograms.patch_counts_kernel.signatures)
    assert loaded >= 1
    q = histograms.quantize(np.zeros((20, 30, 3), np.uint8), 16)
    tbp_like = np.zeros((5, 6, 3))[:, 2]
    for states in (tbp_like, np.zeros((4, 3), np.float32), np.zeros(3)):
        histograms.patch_histograms(q, states, np.ones((2, 4)), 6)
    assert len(histograms.patch_counts_kernel.signatures) == loaded
