"""Colour models of Ude & Atkeson: Gaussian mixtures in colour space (eqs. 6-7).

Two colour spaces, as in the paper:

* ``"rgb"``: 3-D, ``I = (R, G, B) / 255`` in [0, 1]^3 (skin).
* ``"hs"``: 2-D hue-saturation of HSV, value (intensity) ignored (coloured objects). Hue is a
  fraction of a turn in [0, 1) and *circular*: differences to a component mean are wrapped into
  [-0.5, 0.5) (a wrapped-normal approximation, exact while sigma_hue << 1), so red objects whose
  hue straddles 0 work.

Both colour spaces have unit volume, so the uniform outlier's colour density is 1.
Densities are per unit colour volume. :class:`ColorLUT` tabulates a model over quantised 8-bit
RGB for fast per-pixel lookup in the trackers.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from humimic.maths.jit import njit

SPACES = {"rgb": 3, "hs": 2}
FORMAT = "humimic.color_model"
VERSION = 1
_LOG_2PI = float(np.log(2.0 * np.pi))


def rgb_to_hs(rgb: np.ndarray) -> np.ndarray:
    """RGB in [0, 1] ``(..., 3)`` to (hue in [0, 1), saturation in [0, 1]) ``(..., 2)``.

    OpenCV's RGB->HSV on float32 (``S = (max - min) / max``, 0 for black; hue in degrees):
    7.8x faster than the numpy formula it replaced, equal to 5e-6 (float32).
    """
    rgb = np.asarray(rgb, dtype=np.float32)
    if rgb.size == 0:
        return np.zeros((*rgb.shape[:-1], 2))
    hsv = cv2.cvtColor(rgb.reshape(-1, 1, 3), cv2.COLOR_RGB2HSV).reshape(*rgb.shape[:-1], 3)
    return np.stack([(hsv[..., 0] / 360.0) % 1.0, hsv[..., 1]], axis=-1).astype(np.float64)


def features(rgb: np.ndarray, space: str) -> np.ndarray:
    """Colour features of pixels ``(..., 3)`` (uint8 0..255 or float 0..1) in ``space``."""
    if space not in SPACES:
        raise ValueError(f"unknown colour space {space!r}; expected one of {sorted(SPACES)}")
    rgb = np.asarray(rgb)
    x = rgb.astype(np.float64) / 255.0 if rgb.dtype == np.uint8 else rgb.astype(np.float64)
    return x if space == "rgb" else rgb_to_hs(x)


def _diff(X: np.ndarray, means: np.ndarray, circular: bool) -> np.ndarray:
    """``X[:, None] - means[None]`` ``(N, n, d)``, hue (dim 0) wrapped into [-0.5, 0.5)."""
    d = X[:, None, :] - means[None, :, :]
    if circular:
        d[..., 0] = (d[..., 0] + 0.5) % 1.0 - 0.5
    return d


def gmm_component_log_density(
    X: np.ndarray, means: np.ndarray, covs: np.ndarray, circular: bool = False
) -> np.ndarray:
    """``log N(X_i | mean_k, cov_k)`` for points ``(N, d)`` and components: ``(N, n)``.  # eq. 7"""
    X = np.asarray(X, dtype=np.float64)
    d = X.shape[-1]
    L = np.linalg.cholesky(covs)  # (n, d, d)
    Linv = np.linalg.inv(L)
    z = np.einsum("kij,nkj->nki", Linv, _diff(X, means, circular))
    maha = np.einsum("nki,nki->nk", z, z)
    logdet = 2.0 * np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(-1)
    return -0.5 * (maha + logdet[None, :] + d * _LOG_2PI)  # Ude eq. 7


def gmm_log_density(
    X: np.ndarray, weights: np.ndarray, means: np.ndarray, covs: np.ndarray,
    circular: bool = False,
) -> np.ndarray:
    """``log sum_k w_k N(X | mean_k, cov_k)`` ``(N,)`` (log-sum-exp).  # Ude eq. 6"""
    lc = gmm_component_log_density(X, means, covs, circular) + np.log(weights)[None, :]
    m = lc.max(axis=1, keepdims=True)
    return (m + np.log(np.exp(lc - m).sum(axis=1, keepdims=True)))[:, 0]


@dataclass(frozen=True)
class ColorModel:
    """A colour GMM ``p(I | Theta_l)`` (Ude eq. 6) in colour space ``space``."""

    space: str
    weights: np.ndarray
    means: np.ndarray
    covs: np.ndarray
    name: str = ""

    def __post_init__(self) -> None:
        _validate(self.space, self.weights, self.means, self.covs, source="ColorModel")

    @property
    def circular(self) -> bool:
        return self.space == "hs"

    def likelihood(self, rgb: np.ndarray) -> np.ndarray:
        """Per-pixel colour density ``p(I_u | Theta)`` for pixels ``(..., 3)``: shape ``(...)``."""
        rgb = np.asarray(rgb)
        X = features(rgb.reshape(-1, 3), self.space)
        logp = gmm_log_density(X, self.weights, self.means, self.covs, self.circular)
        return np.exp(logp).reshape(rgb.shape[:-1])


def _validate(space, weights, means, covs, source: str) -> None:
    if space not in SPACES:
        raise ValueError(f"{source}: unknown colour space {space!r}; expected 'rgb' or 'hs'")
    d = SPACES[space]
    w, m, c = np.asarray(weights), np.asarray(means), np.asarray(covs)
    n = w.shape[0] if w.ndim == 1 else -1
    if n < 1 or m.shape != (n, d) or c.shape != (n, d, d):
        raise ValueError(f"{source}: bad shapes weights {w.shape}, means {m.shape}, covs "
                         f"{c.shape} for {n} components in {d}-D space {space!r}")
    if not (np.all(np.isfinite(w)) and np.all(np.isfinite(m)) and np.all(np.isfinite(c))):
        raise ValueError(f"{source}: non-finite numbers")
    if np.any(w < 0) or abs(w.sum() - 1.0) > 1e-6:
        raise ValueError(f"{source}: mixture weights must be >= 0 and sum to 1 (sum {w.sum()})")
    if np.any(np.linalg.eigvalsh(0.5 * (c + np.swapaxes(c, 1, 2))) <= 0):
        raise ValueError(f"{source}: covariances must be positive definite")


def _kmeans_pp(X: np.ndarray, n: int, rng: np.random.Generator, circular: bool) -> np.ndarray:
    centres = [X[rng.integers(len(X))]]
    for _ in range(1, n):
        d2 = np.min(np.square(_diff(X, np.array(centres), circular)).sum(-1), axis=1)
        p = d2 / d2.sum() if d2.sum() > 0 else np.full(len(X), 1.0 / len(X))
        centres.append(X[rng.choice(len(X), p=p)])
    return np.array(centres)


def fit_gmm(
    X: np.ndarray, n_components: int, rng: np.random.Generator, circular: bool = False,
    max_iter: int = 300, tol: float = 1e-7, reg_covar: float = 1e-6,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]:
    """Maximum-likelihood GMM by EM; k-means++ seeding from ``rng``. Hand-written because hue
    is circular: ``cv2.ml.EM`` and ``cv2.kmeans`` have no wrapped dimension.

    Returns ``(weights, means, covs, mean_loglik_per_iteration)``. ``reg_covar`` is added to each
    covariance diagonal (about 8-bit quantisation noise, (1/255)^2/12 ~ 1.3e-6). With ``circular``
    the first coordinate has period 1 (hue): means are updated by wrapped mean differences.
    """
    X = np.asarray(X, dtype=np.float64)
    N, d = X.shape
    if N < n_components * (d + 1):
        raise ValueError(f"too few samples ({N}) for {n_components} components in {d}-D")
    means = _kmeans_pp(X, n_components, rng, circular)
    covs = np.repeat((np.cov(X.T).reshape(d, d) + reg_covar * np.eye(d))[None], n_components, 0)
    weights = np.full(n_components, 1.0 / n_components)
    history: list[float] = []
    for _ in range(max_iter):
        lc = gmm_component_log_density(X, means, covs, circular) + np.log(weights)[None]
        m = lc.max(axis=1, keepdims=True)
        lse = m + np.log(np.exp(lc - m).sum(axis=1, keepdims=True))
        history.append(float(lse.mean()))
        resp = np.exp(lc - lse)  # (N, n)
        nk = resp.sum(0) + 1e-300
        weights = nk / N
        diff = _diff(X, means, circular)  # relative to the old means (wrapped)
        shift = np.einsum("nk,nki->ki", resp, diff) / nk[:, None]
        means = means + shift
        if circular:
            means[:, 0] %= 1.0
        diff = diff - shift[None]
        covs = np.einsum("nk,nki,nkj->kij", resp, diff, diff) / nk[:, None, None]
        covs += reg_covar * np.eye(d)[None]
        if len(history) > 1 and abs(history[-1] - history[-2]) < tol:
            break
    return weights, means, covs, history


def fit_color_model(
    rgb_pixels: np.ndarray, space: str, n_components: int, rng: np.random.Generator,
    name: str = "", **kwargs,
) -> ColorModel:
    """Learn a colour model from labelled pixels ``(N, 3)`` (uint8 or float in [0, 1])."""
    X = features(np.asarray(rgb_pixels).reshape(-1, 3), space)
    w, m, c, _ = fit_gmm(X, n_components, rng, circular=(space == "hs"), **kwargs)
    return ColorModel(space, w, m, c, name)


def save_color_model(model: ColorModel, path: str | Path) -> None:
    """Write ``model`` to a small ``.json`` or ``.npz`` file (chosen by the suffix)."""
    path = Path(path)
    data = {"format": FORMAT, "version": VERSION, "space": model.space, "name": model.name,
            "weights": model.weights, "means": model.means, "covs": model.covs}
    if path.suffix == ".json":
        out = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in data.items()}
        path.write_text(json.dumps(out, indent=1))
    elif path.suffix == ".npz":
        np.savez(path, **{k: np.asarray(v) for k, v in data.items()})
    else:
        raise ValueError(f"colour model file must end in .json or .npz: {path}")


def load_color_model(path: str | Path) -> ColorModel:
    """Read a colour model written by :func:`save_color_model`; clear errors for bad files."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"colour model file not found: {path}")
    try:
        if path.suffix == ".json":
            raw = json.loads(path.read_text())
        elif path.suffix == ".npz":
            with np.load(path, allow_pickle=False) as z:
                raw = {k: (z[k].item() if z[k].ndim == 0 else z[k]) for k in z.files}
        else:
            raise ValueError("suffix must be .json or .npz")
        if not isinstance(raw, dict) or raw.get("format") != FORMAT:
            raise ValueError(f"not a {FORMAT} file")
        missing = [k for k in ("space", "weights", "means", "covs") if k not in raw]
        if missing:
            raise ValueError(f"missing keys {missing}")
        return ColorModel(str(raw["space"]), np.asarray(raw["weights"], dtype=np.float64),
                          np.asarray(raw["means"], dtype=np.float64),
                          np.asarray(raw["covs"], dtype=np.float64), str(raw.get("name", "")))
    except (ValueError, KeyError, TypeError, OSError) as e:  # json.JSONDecodeError is a ValueError
        raise ValueError(f"malformed colour model file {path}: {e}") from e


class ColorLUT:
    """A colour model tabulated on quantised 8-bit RGB (``bits`` per channel, bin centres).

    ``lookup(rgb_u8)`` costs a few integer ops and one gather per pixel; the error against the
    exact density is a quantisation of the colour by up to half a bin (2 levels at 6 bits).
    """

    def __init__(self, model: ColorModel, bits: int = 6, table: np.ndarray | None = None
                 ) -> None:
        if not 1 <= bits <= 8:
            raise ValueError(f"bits must be in 1..8, got {bits}")
        self.model = model
        self.bits = bits
        self.shift = 8 - bits
        n = 1 << bits
        if table is not None:  # tabulated before (a cached LUT): ``self.table`` of that LUT
            if table.shape != (n**3,):
                raise ValueError(f"a {bits}-bit table has {n**3} entries, got {table.shape}")
            self.table = np.asarray(table, np.float32)
        else:
            step = 1 << self.shift
            centres = (np.arange(n) * step + 0.5 * (step - 1)) / 255.0
            grid = np.stack(np.meshgrid(centres, centres, centres, indexing="ij"),
                            -1).reshape(-1, 3)
            self.table = model.likelihood(grid).astype(np.float32)
        self.post_table = self.table / (self.table + 1.0)
        """``p / (p + 1)`` per bin (float32, as computed on looked-up densities)."""
        self._masks: dict[float, np.ndarray] = {}
        """:meth:`mask`'s uint8 tables by threshold."""
        self.look_alike: float | None = None
        """For a model learned from the scene's renders: the scene's pixels it takes for the
        class per class pixel (:func:`~humimic.perception.cues.auto_colors.look_alike_ratio`);
        None otherwise."""
        self.class_lost: float | None = None
        """For a model learned from the scene's renders: the share of the class's own pixels
        its table does not take for the class
        (:func:`~humimic.perception.cues.auto_colors.lost_fraction`); None otherwise."""

    def index(self, rgb_u8: np.ndarray) -> np.ndarray:
        """Table index (int32) of uint8 pixels ``(..., 3)``: ``r' 2^(2 bits) + g' 2^bits +
        b'`` of the channels shifted to ``bits``, built in place in one int32 array (fewer
        passes, and none over int64 temporaries)."""
        q = np.asarray(rgb_u8, dtype=np.uint8)
        shift = self.shift
        if shift and q.ndim > 1 and q.strides[-2] == 3:    # adjacent pixels: one shift pass
            q, shift = q >> shift, 0
        i = q[..., 0].astype(np.int32)    # else per channel (a[::2, ::2]: 2-D strided passes)
        if shift:
            i >>= shift
        for c in (1, 2):
            i <<= self.bits
            i |= q[..., c] >> shift if shift else q[..., c]
        return i

    def lookup(self, rgb_u8: np.ndarray) -> np.ndarray:
        """Colour density for uint8 pixels ``(..., 3)``: float32 ``(...)``.  # Ude eq. 6"""
        return np.take(self.table, self.index(rgb_u8))

    def posterior(self, rgb_u8: np.ndarray) -> np.ndarray:
        """``p / (p + 1)`` of :meth:`lookup` (the probability of the colour against the uniform
        outlier density 1), float32, from a table; an ``(h, w, 3)`` uint8 image (any strides:
        a view of a region) in one compiled pass (:func:`_posterior_image`)."""
        if getattr(rgb_u8, "ndim", 0) == 3 and rgb_u8.shape[2] == 3 and rgb_u8.dtype == np.uint8:
            return _posterior_image(rgb_u8, self.post_table, self.bits)
        return np.take(self.post_table, self.index(rgb_u8))

    def mask(self, rgb_u8: np.ndarray, threshold: float = 0.5) -> np.ndarray:
        """``(posterior(rgb_u8) > threshold)`` as uint8 0/1, from a uint8 table (one gather,
        no float image)."""
        return np.take(self.mask_table(threshold), self.index(rgb_u8))

    def mask_table(self, threshold: float = 0.5) -> np.ndarray:
        """:meth:`mask`'s uint8 table (0/1 per bin, indexed as :meth:`index`)."""
        table = self._masks.get(threshold)
        if table is None:
            table = self._masks[threshold] = (self.post_table > threshold).astype(np.uint8)
        return table


@njit(inline="always")
def lut_index(r, g, b, bits):
    """:meth:`ColorLUT.index` of one pixel's uint8 channels ``r, g, b`` at ``bits`` per
    channel, for compiled loops (the one compiled form; tested against the method)."""
    shift = np.uint32(8 - bits)
    return (((np.uint32(r) >> shift) << np.uint32(2 * bits))
            | ((np.uint32(g) >> shift) << np.uint32(bits)) | (np.uint32(b) >> shift))


@njit
def _posterior_image(image: np.ndarray, post_table: np.ndarray, bits: int) -> np.ndarray:
    """:meth:`ColorLUT.posterior` of an ``(h, w, 3)`` uint8 image: the table at every pixel's
    :func:`lut_index`, float32 ``(h, w)`` (numpy's index and gather passes cost ~4x more on
    the 2-D hand tracker's 125 x 147 cue box)."""
    h, w = image.shape[0], image.shape[1]
    out = np.empty((h, w), np.float32)
    for y in range(h):
        for x in range(w):
            out[y, x] = post_table[lut_index(image[y, x, 0], image[y, x, 1], image[y, x, 2],
                                             bits)]
    return out


def load_posterior_kernels() -> None:
    """Compile (or load from numba's disk cache) :func:`_posterior_image` for whole images
    and for views with other strides (a region of an image: two specialisations), on a tiny
    image, so that a stage's first frame -- or the first frame that needs it, as Ude's stereo
    matching of colour-masked crops -- does not pay for it."""
    table = np.zeros(8, np.float32)                       # a 1-bit table, as post_table
    _posterior_image(np.zeros((2, 2, 3), np.uint8), table, 1)
    _posterior_image(np.zeros((4, 4, 3), np.uint8)[::2, ::2], table, 1)
