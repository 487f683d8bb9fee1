"""Faces: the head texture's mapping, identities in scenarios, detection of rendered faces,
eigenface recognition (Menezes eqs. 10-11) and the model cache."""

from __future__ import annotations

import cv2
import mujoco
import numpy as np
import pytest

from humimic import cache
from humimic.perception.faces import training
from humimic.perception.faces.detect import (
    FaceDetector,
    crop_faces,
    equalize,
    face_mask,
    matches_truth,
)
from humimic.perception.faces.eigenfaces import (
    EigenfaceModel,
    class_probabilities,
    dffs,
    fit_pca,
    train,
)
from humimic.perception.faces.rates import detection_rates
from humimic.perception.faces.studio import FaceStudio, FaceView
from humimic.scenario.errors import ScenarioError
from humimic.scenario.load import validate_scenario
from humimic.world.faces import (
    DEFAULT_IDENTITY,
    IDENTITY_NAMES,
    cube_directions,
    png_bytes,
    resolve_identity,
)


def test_cube_directions_are_how_mujoco_samples_an_ellipsoid():
    """Colour every texel by the signs of its direction (R: y > 0, G: z > 0, B: x > 0) and
    look at the rendered ellipsoid from four sides: each quadrant shows its own signs."""
    size = 32
    files = {}
    for face, u in cube_directions(size).items():
        img = (np.stack([u[..., 1] > 0, u[..., 2] > 0, u[..., 0] > 0], -1) * 255).astype(np.uint8)
        files[f"{face}.png"] = png_bytes(img)
    tex = " ".join(f'file{f}="{f}.png"' for f in ("right", "left", "up", "down", "front", "back"))
    xml = f"""<mujoco><asset><texture name="t" type="cube" {tex}/>
      <material name="m" texture="t"/></asset>
      <visual><headlight ambient="1 1 1" diffuse="0 0 0" specular="0 0 0"/></visual>
      <worldbody><geom type="ellipsoid" size="0.095 0.078 0.115" material="m"/>
      <camera name="px" pos="2 0 0" xyaxes="0 1 0 0 0 1" fovy="8"/>
      <camera name="py" pos="0 2 0" xyaxes="-1 0 0 0 0 1" fovy="8"/>
      <camera name="mx" pos="-2 0 0" xyaxes="0 -1 0 0 0 1" fovy="8"/>
      <camera name="pz" pos="0 0 2" xyaxes="0 1 0 -1 0 0" fovy="8"/>
      </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml, files)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    # per camera: the direction of the image's right and up axes, and its viewing axis
    views = {"px": ((0, 1, 0), (0, 0, 1), (1, 0, 0)), "py": ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
             "mx": ((0, -1, 0), (0, 0, 1), (-1, 0, 0)), "pz": ((0, 1, 0), (-1, 0, 0), (0, 0, 1))}
    with mujoco.Renderer(m, 200, 200) as r:
        for cam, (right, up, toward) in views.items():
            r.update_scene(d, cam)
            img = r.render()
            for sx in (-1, 1):
                for sy in (-1, 1):
                    px = img[100 - sy * 14, 100 + sx * 9]  # inside the quadrant, off the seams
                    direction = sx * np.array(right) + sy * np.array(up) + np.array(toward)
                    expect = np.array([direction[1] > 0, direction[2] > 0, direction[0] > 0])
                    np.testing.assert_array_equal(px > 127, expect, err_msg=f"{cam} {sx} {sy}")


def test_rendered_faces_are_upright_and_found():
    det = FaceDetector()
    for name in IDENTITY_NAMES[:3]:
        with FaceStudio(name, "L_foveal") as s:
            shot = s.render(FaceView(distance=2.0))
        boxes = det.detect(shot.image)
        assert matches_truth(boxes, shot.center_px, shot.size_px).any(), name
        # the same frame upside down is not a face to the cascade
        flipped = det.detect(np.ascontiguousarray(shot.image[::-1]))
        c = shot.center_px * [1, 1]
        c[1] = shot.image.shape[0] - 1 - c[1]
        assert not matches_truth(flipped, c, shot.size_px).any(), name


@pytest.mark.slow
def test_detection_rate_of_rendered_faces_at_24_px_and_more():
    """Every identity, both eye cameras, frontal views at 24-60 px: >= 90 % found (issue 12);
    measured 97-98 % over 382 frames with ``perception/faces/rates.py``."""
    tab = detection_rates(list(IDENTITY_NAMES), bins=(24.0, 30.0, 40.0, 60.0), per_bin=1,
                          seed=3)
    n = sum(tab.trials.values())
    assert n >= 70
    # measured 2026-11-29: 0.975 of 80 found (2 missed), 1 false detection
    assert tab.overall() >= 0.94, (tab.hits, tab.trials)
    assert tab.false_detections <= 3


def test_identity_in_a_scenario():
    def load(identity):
        return validate_scenario({"name": "x", "duration": 1.0, "human": {"identity": identity}},
                                 "s.yaml")

    assert load("ben").human.identity == "ben"
    assert load(2).human.identity == IDENTITY_NAMES[2]
    assert validate_scenario({"name": "x", "duration": 1.0}, "s.yaml").human.identity == (
        DEFAULT_IDENTITY)
    with pytest.raises(ScenarioError, match=r"human\.identity.*did you mean 'gus'"):
        load("guss")
    with pytest.raises(ScenarioError, match=r"human\.identity: out of range"):
        load(len(IDENTITY_NAMES))
    assert len(IDENTITY_NAMES) >= 10 and len(set(IDENTITY_NAMES)) == len(IDENTITY_NAMES)
    with pytest.raises(ValueError, match="did you mean"):
        resolve_identity("adaa")


def test_crops_are_equalised_inside_the_face_mask():
    rng = np.random.default_rng(0)
    img = (rng.random((240, 320)) * 80 + 60).astype(np.uint8)
    crops = crop_faces(img, np.array([[100, 50, 40, 40], [300, 220, 40, 40]]))
    mask = face_mask()
    assert crops.shape == (2, 30, 30) and np.all(crops[:, ~mask] == 0)
    assert crops[0][mask].min() <= 5 and crops[0][mask].max() >= 250  # stretched to 0..255
    plain = equalize(img[None, :30, :30], mask=None, blur_sigma=0.0)[0]
    np.testing.assert_array_equal(plain, cv2.equalizeHist(img[:30, :30]))


# ---- eigenfaces ---------------------------------------------------------------------------
def _classes(rng, n_classes=4, n=40, dim=900, rank=5):
    """Synthetic classes: each a low-rank Gaussian around its own mean."""
    out = {}
    for c in range(n_classes):
        mean = rng.random(dim)
        basis = np.linalg.qr(rng.normal(size=(dim, rank)))[0].T
        coeff = rng.normal(0, [3.0, 2.0, 1.5, 1.0, 0.5], (n, rank))
        out[f"c{c}"] = mean + coeff @ basis + rng.normal(0, 0.01, (n, dim))
    return out


def test_pca_spans_the_leading_eigenvectors_of_the_covariance():
    X = _classes(np.random.default_rng(1))["c0"]
    mean, basis = fit_pca(X, variance=0.95)
    w, V = np.linalg.eigh(np.cov(X.T, bias=True))
    order = np.argsort(w)[::-1]
    k = int(np.searchsorted(np.cumsum(w[order]) / w.sum(), 0.95) + 1)
    assert len(basis) == k
    P_ref = V[:, order[:k]] @ V[:, order[:k]].T
    np.testing.assert_allclose(basis.T @ basis, P_ref, atol=1e-6)
    np.testing.assert_allclose(mean, X.mean(axis=0))
    # eq. 10: L1 norm of the residual after projection, against the eigh basis
    Y = np.random.default_rng(2).random((5, 900))
    ref = np.abs((Y - mean) - (Y - mean) @ P_ref).sum(axis=1)
    np.testing.assert_allclose(dffs(Y, mean, basis), ref, rtol=1e-6)


def test_eq11_class_probabilities_and_void_class():
    D = np.array([[3.0, 5.0, 9.0], [11.0, 12.0, 30.0], [10.0, 2.0, 2.0]])
    p = class_probabilities(D, tau=10.0, sigma=4.0)
    g = np.exp(-0.5 * (D[0] / 4.0) ** 2)
    np.testing.assert_allclose(p[0, :3], g / g.sum())
    np.testing.assert_array_equal(p[1], [0, 0, 0, 1])  # every D > tau: the void class
    assert p[2, 3] == 0 and np.isclose(p[2, 1], p[2, 2])
    np.testing.assert_allclose(p.sum(axis=1), 1.0)


def test_eigenface_model_classifies_and_round_trips():
    rng = np.random.default_rng(3)
    classes = _classes(rng)
    crops = {k: np.clip(v * 40 + 60, 0, 255).astype(np.uint8).reshape(-1, 30, 30)
             for k, v in classes.items()}
    train_part = {k: v[:30] for k, v in crops.items()}
    test_part = {k: v[30:] for k, v in crops.items()}
    model = training.fit(train_part, far=0.05)
    for i, (_, c) in enumerate(test_part.items()):
        label, prob = model.classify(c)
        assert np.mean(label == i) >= 0.9 and np.all(prob > 0)
    stranger = rng.integers(0, 256, (10, 30, 30), dtype=np.uint8)
    assert np.all(model.classify(stranger)[0] == -1)
    again = EigenfaceModel.from_arrays(model.to_arrays())
    np.testing.assert_array_equal(again.probabilities(stranger), model.probabilities(stranger))
    assert again.names == model.names and again.tau == model.tau
    with pytest.raises(ValueError, match="crops"):
        train({"a": np.zeros((1, 30, 30), np.uint8)})


def test_cache_dir_key_and_round_trip(tmp_path, monkeypatch):
    monkeypatch.setenv("HUMIMIC_CACHE_DIR", str(tmp_path))
    assert cache.cache_dir() == tmp_path
    k1, k2 = cache.key(1, "a", b"x"), cache.key(1, "a", b"y")
    assert k1 != k2 and k1 == cache.key(1, "a", b"x")
    assert cache.load("thing", k1) is None
    cache.save("thing", k1, {"a": np.arange(3)})
    np.testing.assert_array_equal(cache.load("thing", k1)["a"], np.arange(3))
    cache.path("thing", k2).write_bytes(b"not a zip")
    assert cache.load("thing", k2) is None
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.slow
def test_recognition_of_rendered_faces(tmp_path, monkeypatch):
    """Train on 4 identities (rendered, detected, cropped), test on held-out renders of them
    and of 2 strangers. Measured: closed-set 1.0, 0.95 right at <= 10 % strangers accepted,
    0.95 right at the automatic tau (which, estimated from 3 other classes only, accepts one
    of the two strangers 60 % of the time: with the 10 enrolled people of
    ``python -m humimic.perception.faces recognition`` strangers are accepted 1 %)."""
    monkeypatch.setenv("HUMIMIC_CACHE_DIR", str(tmp_path))
    names = list(IDENTITY_NAMES[:6])
    spec = training.RenderSpec(per_identity=40, yaw_deg=12.0, seed=5)
    model = training.trained_model(names[:4], spec)
    assert list(tmp_path.glob("eigenfaces-*.npz"))  # cached
    test = training.render_sets(names, training.RenderSpec(per_identity=15, yaw_deg=12.0,
                                                           seed=6))
    known = {n: test[n].crops for n in names[:4]}
    X = np.concatenate(list(known.values()))
    true = np.repeat(np.arange(4), [len(v) for v in known.values()])
    assert np.mean(np.argmin(model.distances(X), axis=1) == true) >= 0.95  # measured 1.0
    roc = training.roc(model, known, {n: test[n].crops for n in names[4:]})
    assert roc.at_far(0.1)[0] >= 0.8  # measured 0.92 (2026-11-29)
    assert np.mean(model.classify(X)[0] == true) >= 0.85  # measured 0.93
