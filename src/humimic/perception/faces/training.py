"""Train the eigenface recogniser on rendered faces, choose its threshold, measure its ROC.

Training data are what the recogniser will see: the avatar rendered through the robot's eye
cameras (wide and foveal, 320 x 240) at face sizes of 24-80 px, under random head poses,
lighting and skin tones, and cropped where the Haar cascade found the face (detections off
the face are discarded). Everything is seeded; the trained model is cached
(:mod:`humimic.cache`) under a hash of the identities' crops, the scene's model files, the
render and detector settings and this module's version.

Choosing ``tau`` automatically: a fraction ``validation`` of each class's crops is held out;
the eigenspaces are fit on the rest; for each held-out crop of class ``l`` its distance to its
own class is a *genuine* score and its least distance to any other class an *impostor* score
(someone else's face, as a stranger's would be). ``tau`` is the ``far`` quantile of the
impostor scores (that fraction of impostors accepted) and ``sigma`` (eq. 11's spread) the
standard deviation of the genuine scores. The final eigenspaces are refit on all crops.
With ``far = 0.05`` (the default), held-out strangers -- six identities never trained on --
were accepted 1.0 % of the time: the enrolled faces are closer to one another than strangers
are to them, so the validation impostors are the harder case. The rule needs several enrolled
people: with 4 (3 "others" per class) tau came out 35 % higher and let a stranger in 60 % of
the time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from humimic import cache
from humimic.paths import MODELS_DIR
from humimic.perception.faces.detect import DetectorParams, FaceDetector, crop_faces, matches_truth
from humimic.perception.faces.eigenfaces import EigenfaceModel, train
from humimic.perception.faces.studio import FaceStudio, FaceView, size_to_distance
from humimic.world.faces import FACES_DIR
from humimic.world.names import EYE_HFOV_DEG

VERSION = 1
SKIN_TONES = ((0.95, 0.80, 0.70), (0.87, 0.67, 0.55), (0.76, 0.57, 0.45), (0.62, 0.45, 0.34),
              (0.45, 0.32, 0.24))
"""Light to dark skin colours (RGB) the training renders are drawn with."""


@dataclass(frozen=True)
class RenderSpec:
    """The distribution of rendered views a crop set is drawn from."""

    per_identity: int = 100
    size_px: tuple[float, float] = (24.0, 80.0)
    yaw_deg: float = 25.0
    pitch_deg: float = 15.0
    roll_deg: float = 10.0
    cameras: tuple[str, ...] = ("foveal", "wide")
    distances: tuple[float, float] = (0.45, 4.5)
    skins: tuple[tuple[float, float, float], ...] = SKIN_TONES
    seed: int = 0


def random_view(spec: RenderSpec, camera: str, rng: np.random.Generator) -> FaceView | None:
    """A view of the spec's distribution for ``camera``; None if the drawn size is out of the
    camera's reach at the allowed distances."""
    size = float(np.exp(rng.uniform(*np.log(spec.size_px))))
    dist = size_to_distance(size, EYE_HFOV_DEG[camera])
    if not spec.distances[0] <= dist <= spec.distances[1]:
        return None
    off = 0.1 * dist
    skin = spec.skins[rng.integers(len(spec.skins))]
    return FaceView(distance=dist, yaw_deg=rng.uniform(-spec.yaw_deg, spec.yaw_deg),
                    pitch_deg=rng.uniform(-spec.pitch_deg, spec.pitch_deg),
                    roll_deg=rng.uniform(-spec.roll_deg, spec.roll_deg),
                    ambient=rng.uniform(0.15, 0.45), diffuse=rng.uniform(0.35, 0.75),
                    aim_offset=(rng.uniform(-off, off), 0.6 * rng.uniform(-off, off)),
                    skin=tuple(np.clip(np.asarray(skin) * rng.uniform(0.92, 1.08, 3), 0, 1)))


@dataclass(frozen=True)
class CropSet:
    """Detected face crops of one identity and the views they came from."""

    crops: np.ndarray
    """``(n, 30, 30)`` uint8, equalised (:func:`~.detect.crop_faces`)."""
    size_px: np.ndarray
    yaw_deg: np.ndarray
    renders: int
    """Frames rendered to get them (the rest had no detection on the face)."""


def render_crops(identity: str, spec: RenderSpec, detector: FaceDetector,
                 rng: np.random.Generator) -> CropSet:
    """Up to ``spec.per_identity`` detected face crops of ``identity`` (at most 3 renders per
    crop wanted)."""
    crops, sizes, yaws, renders = [], [], [], 0
    with FaceStudio(identity, tuple(f"L_{c}" for c in spec.cameras), rng=rng) as studio:
        while len(crops) < spec.per_identity and renders < 3 * spec.per_identity:
            cam = spec.cameras[rng.integers(len(spec.cameras))]
            view = random_view(spec, cam, rng)
            if view is None:
                continue
            shot = studio.render(view, f"L_{cam}")
            renders += 1
            boxes = detector.detect(shot.image)
            ok = matches_truth(boxes, shot.center_px, shot.size_px)
            if ok.any():
                crops.append(crop_faces(shot.image, boxes[ok][:1])[0])
                sizes.append(shot.size_px)
                yaws.append(view.yaw_deg)
    return CropSet(np.array(crops, np.uint8).reshape(-1, 30, 30), np.array(sizes),
                   np.array(yaws), renders)


def render_sets(identities: list[str], spec: RenderSpec, params: DetectorParams | None = None,
                progress: Callable[[], None] | None = None) -> dict[str, CropSet]:
    """Crops for every identity (one seeded stream per identity)."""
    det = FaceDetector(params)
    out = {}
    for i, name in enumerate(identities):
        out[name] = render_crops(name, spec, det, np.random.default_rng([spec.seed, i]))
        if progress is not None:
            progress()
    return out


def scores(model: EigenfaceModel, crops_by_class: dict[str, np.ndarray]
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For crops of the model's classes: genuine distance, least impostor distance and whether
    the least distance overall is the right class."""
    gen, imp, right = [], [], []
    for li, name in enumerate(model.names):
        D = model.distances(crops_by_class[name])
        if len(D) == 0:
            continue
        others = np.delete(D, li, axis=1)
        gen.append(D[:, li])
        imp.append(others.min(axis=1))
        right.append(np.argmin(D, axis=1) == li)
    return np.concatenate(gen), np.concatenate(imp), np.concatenate(right)


def fit(crops_by_class: dict[str, np.ndarray], far: float = 0.05, validation: float = 0.3,
        variance: float = 0.95, seed: int = 0) -> EigenfaceModel:
    """Eigenspaces for every class with ``tau`` and ``sigma`` chosen on held-out crops."""
    rng = np.random.default_rng(seed)
    fit_part, held = {}, {}
    for name, c in crops_by_class.items():
        idx = rng.permutation(len(c))
        k = max(1, int(round(validation * len(c))))
        held[name], fit_part[name] = c[idx[:k]], c[idx[k:]]
    gen, imp, _ = scores(train(fit_part, variance), held)
    tau = float(np.quantile(imp, far))
    sigma = float(max(np.std(gen), 1e-6))
    return train(crops_by_class, variance).with_threshold(tau, sigma)


def model_key(identities: list[str], spec: RenderSpec, params: DetectorParams, far: float,
              variance: float) -> str:
    """The cache key: everything that changes the trained model."""
    files = [FACES_DIR / f"{n}.png" for n in identities]
    models = sorted(MODELS_DIR.glob("*.xml"))
    return cache.key(VERSION, identities, files, models, spec, params, far, variance)


def trained_model(identities: list[str], spec: RenderSpec | None = None,
                  params: DetectorParams | None = None, far: float = 0.05,
                  variance: float = 0.95, progress: Callable[[], None] | None = None
                  ) -> EigenfaceModel:
    """The recogniser for ``identities``: from the cache, or rendered, trained and cached."""
    spec, params = spec or RenderSpec(), params or DetectorParams()
    digest = model_key(identities, spec, params, far, variance)
    stored = cache.load("eigenfaces", digest)
    if stored is not None:
        return EigenfaceModel.from_arrays(stored)
    sets = render_sets(identities, spec, params, progress)
    model = fit({k: v.crops for k, v in sets.items()}, far, variance=variance, seed=spec.seed)
    cache.save("eigenfaces", digest, model.to_arrays())
    return model


@dataclass(frozen=True)
class Roc:
    """Open-set recognition on a test set, as a function of ``tau``."""

    tau: np.ndarray
    correct: np.ndarray
    """Fraction of known faces accepted *and* given the right name."""
    false_accept: np.ndarray
    """Fraction of strangers' faces accepted as someone known."""
    misidentified: np.ndarray
    """Fraction of known faces accepted under a wrong name."""

    def at_far(self, far: float) -> tuple[float, float]:
        """Best correct rate with false acceptance at most ``far``, and the tau giving it."""
        ok = self.false_accept <= far
        if not ok.any():
            return 0.0, float("nan")
        i = np.flatnonzero(ok)[np.argmax(self.correct[ok])]
        return float(self.correct[i]), float(self.tau[i])


def roc(model: EigenfaceModel, known: dict[str, np.ndarray], strangers: dict[str, np.ndarray],
        n: int = 400) -> Roc:
    """ROC of ``model`` over thresholds: known faces (classes of the model) and strangers."""
    D_known = [(model.names.index(k), model.distances(c)) for k, c in known.items() if len(c)]
    true = np.concatenate([np.full(len(D), li) for li, D in D_known])
    Dk = np.concatenate([D for _, D in D_known])
    best_k, dmin_k = np.argmin(Dk, axis=1), Dk.min(axis=1)
    dmin_s = np.concatenate([model.distances(c).min(axis=1) for c in strangers.values()
                             if len(c)])
    taus = np.quantile(np.concatenate([dmin_k, dmin_s]), np.linspace(0.0, 1.0, n))
    acc_k = dmin_k[None, :] <= taus[:, None]
    correct = np.mean(acc_k & (best_k == true)[None, :], axis=1)
    mis = np.mean(acc_k & (best_k != true)[None, :], axis=1)
    fa = np.mean(dmin_s[None, :] <= taus[:, None], axis=1)
    return Roc(taus, correct, fa, mis)
