"""Eigenface recognition with a void class (Menezes sec. 5.2.1, after Turk & Pentland and
Germa et al. 2007).

Each known person (class ``C_l``) has an eigenspace learnt by PCA from their 30 x 30
histogram-equalised face crops, keeping the leading eigenvectors that explain a fraction
``variance`` of the class's variance. A detected face ``F`` is compared with every class by
its distance from that class's face space:

* eq. 10 -- :func:`dffs`: ``D_l = sum_j |F(j) - F_r,l(j)|``, the L1 norm of the residual after
  projecting ``F`` onto class ``l``'s eigenspace and reconstructing it;
* eq. 11 -- :func:`class_probabilities`: if every ``D_l > tau`` the face is nobody known (the
  void class ``C_void``, probability 1); otherwise ``P(C_l|F) = N(D_l; 0, sigma) / sum_p
  N(D_p; 0, sigma)``.

``tau`` and ``sigma`` are set from data by :mod:`.training` (held-out genuine and impostor
distances): the paper says only that ``tau`` is "predefined automatically".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.perception.faces.detect import CROP_SIZE


def as_vectors(crops: np.ndarray) -> np.ndarray:
    """Crops ``(n, 30, 30)`` uint8 (histogram-equalised) to float rows ``(n, 900)`` in [0, 1]."""
    c = np.asarray(crops)
    return c.reshape(len(c), -1).astype(np.float64) / 255.0


def fit_pca(X: np.ndarray, variance: float = 0.9, max_components: int = 40
            ) -> tuple[np.ndarray, np.ndarray]:
    """Mean ``(D,)`` and orthonormal basis ``(k, D)`` of the leading principal components of
    rows ``X (n, D)`` explaining at least ``variance`` of the total (SVD of the centred data)."""
    X = np.asarray(X, np.float64)
    mean = X.mean(axis=0)
    _, s, vt = np.linalg.svd(X - mean, full_matrices=False)
    energy = np.cumsum(s**2) / max(np.sum(s**2), 1e-300)
    k = int(min(np.searchsorted(energy, variance) + 1, max_components, len(s)))
    return mean, vt[:k]


def dffs(X: np.ndarray, mean: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Menezes eq. 10: ``sum_j |F(j) - F_r(j)|`` for rows ``X (n, D)`` and one eigenspace."""
    Xc = np.asarray(X, np.float64) - mean
    recon = (Xc @ basis.T) @ basis
    return np.abs(Xc - recon).sum(axis=1)  # Menezes eq. 10


def class_probabilities(D: np.ndarray, tau: float, sigma: float) -> np.ndarray:
    """Menezes eq. 11 for distances ``D (n, M)``: ``(n, M + 1)`` probabilities, the last column
    the void class."""
    D = np.asarray(D, np.float64)
    out = np.zeros((len(D), D.shape[1] + 1))
    void = np.all(D > tau, axis=1)
    out[void, -1] = 1.0
    z = -0.5 * (D[~void] / sigma) ** 2
    z -= z.max(axis=1, keepdims=True)
    p = np.exp(z)
    out[~void, :-1] = p / p.sum(axis=1, keepdims=True)  # Menezes eq. 11
    return out


@dataclass(frozen=True)
class EigenfaceModel:
    """Per-class eigenspaces and the decision parameters."""

    names: tuple[str, ...]
    means: np.ndarray
    """``(M, 900)``"""
    bases: tuple[np.ndarray, ...]
    """per class ``(k_l, 900)``"""
    tau: float
    sigma: float

    def distances(self, crops: np.ndarray) -> np.ndarray:
        """DFFS ``(n, M)`` of crops ``(n, 30, 30)`` to every class (eq. 10)."""
        X = as_vectors(crops)
        if len(X) == 0:
            return np.zeros((0, len(self.names)))
        return np.stack([dffs(X, m, b) for m, b in zip(self.means, self.bases, strict=True)],
                        axis=1)

    def probabilities(self, crops: np.ndarray) -> np.ndarray:
        """``(n, M + 1)`` class probabilities, the last column the void class (eq. 11)."""
        return class_probabilities(self.distances(crops), self.tau, self.sigma)

    def classify(self, crops: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Most probable class index per crop (-1: void) and its probability."""
        p = self.probabilities(crops)
        best = np.argmax(p, axis=1)
        label = np.where(best == len(self.names), -1, best)
        return label, p[np.arange(len(p)), best]

    def with_threshold(self, tau: float, sigma: float | None = None) -> EigenfaceModel:
        return EigenfaceModel(self.names, self.means, self.bases, float(tau),
                              float(self.sigma if sigma is None else sigma))

    # ---- storage (humimic.cache) -----------------------------------------------------------
    def to_arrays(self) -> dict[str, np.ndarray]:
        k = np.array([len(b) for b in self.bases])
        return {"names": np.array(self.names), "means": self.means, "k": k,
                "bases": np.concatenate(self.bases), "tau": np.array(self.tau),
                "sigma": np.array(self.sigma)}

    @classmethod
    def from_arrays(cls, a: dict[str, np.ndarray]) -> EigenfaceModel:
        splits = np.cumsum(a["k"])[:-1]
        return cls(tuple(str(n) for n in a["names"]), a["means"],
                   tuple(np.split(a["bases"], splits)), float(a["tau"]), float(a["sigma"]))


def train(crops_by_class: dict[str, np.ndarray], variance: float = 0.9,
          max_components: int = 40) -> EigenfaceModel:
    """One eigenspace per class from its crops ``(n_l, 30, 30)``; ``tau`` = inf, ``sigma`` = 1
    until :mod:`.training` sets them."""
    names = tuple(crops_by_class)
    means, bases = [], []
    for name in names:
        c = np.asarray(crops_by_class[name])
        if c.shape[1:] != (CROP_SIZE, CROP_SIZE) or len(c) < 2:
            raise ValueError(f"class {name!r}: need >= 2 crops of {CROP_SIZE}x{CROP_SIZE}, "
                             f"got {c.shape}")
        m, b = fit_pca(as_vectors(c), variance, max_components)
        means.append(m)
        bases.append(b)
    return EigenfaceModel(names, np.stack(means), tuple(bases), np.inf, 1.0)
