"""The avatar's face: a real face crop on the front of the head, tinted to the skin colour.

A face drawn from ellipses is never found by OpenCV's Haar cascades; real faces are. Each
identity is a 25 x 25 grey face crop from Labeled Faces in the Wild (the subset scikit-image
ships, copied to ``data/faces/``; attribution in ``data/README.md``). The crop becomes a
*shading* texture: grey level divided by the face's median skin level, so plain skin is exactly
1.0 and eyes, brows, nostrils, mouth and hair line are darker. The head material's colour is
the scenario's skin colour and MuJoCo multiplies it by the texture, so a textured head has the
same skin colour as the hands wherever the face has no feature.

The texture is a cube map on the head ellipsoid: every texel is placed at its point on the head
and takes the crop's value where that point, seen from straight ahead (orthographically), falls
on the crop, so the face covers the head's front from brow to chin whatever the cube's seams.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from humimic.errors import unknown_name
from humimic.paths import DATA_DIR

FACES_DIR = DATA_DIR / "faces"
TEXTURE_SIZE = 128
"""Side (px) of each cube-map face: the 25 px crops are upsampled (bicubic) so that close-up
views are smooth."""
FEATURE_CONTRAST = 1.8
"""How much darker than in the photograph the features are drawn (``1 - c (1 - f)``): the
rendered head is lit flatly and tinted. Measured on 240 renders of the 16 identities (both eye
cameras, frontal, 24-90 px): faces of 24-34 px found 82 % at contrast 1.0, 97 % at 1.8; all
sizes 91 % and 99 %."""


@dataclass(frozen=True)
class Identity:
    """A person's face: ``name`` (scenario key ``human.identity``) and its crop file."""

    name: str
    lfw_index: int
    """Index of the crop in ``skimage.data.lfw_subset()`` (provenance)."""


def _identity_table() -> tuple[Identity, ...]:
    rows = (FACES_DIR / "identities.txt").read_text().split("\n")
    out = []
    for row in rows:
        row = row.split("#", 1)[0].strip()
        if row:
            name, index = row.split()
            out.append(Identity(name, int(index)))
    return tuple(out)


IDENTITIES: tuple[Identity, ...] = _identity_table()
IDENTITY_NAMES: tuple[str, ...] = tuple(i.name for i in IDENTITIES)
DEFAULT_IDENTITY = "ben"
"""The face of a scenario that does not choose one. Ude & Atkeson's identity rules assume a head
is one skin blob; a head cut by the image border can split along its dark features, and its
parts looked too small to be the head, so the rules could not name the hand
(``ude_static_hand_foveal``, the chin in a corner of the foveal view, lost the hand with ada,
hal, ivo, kip, ned and oli). Blobs cut by the border are now exempt from the too-small rules
(:mod:`humimic.perception.blobs.identity`; with the colour handling of the time: right-hand
detection 0-2 % -> 96-100 % for ada, kip, oli); the scenario now tracks the hand alone."""


def resolve_identity(key: str | int) -> Identity:
    """The identity named ``key`` or at index ``key`` of :data:`IDENTITIES`.

    Raises ``ValueError`` with the allowed values and a did-you-mean for an unknown one.
    """
    if isinstance(key, int) and not isinstance(key, bool):
        if 0 <= key < len(IDENTITIES):
            return IDENTITIES[key]
        raise ValueError(f"identity index {key} out of range; allowed 0..{len(IDENTITIES) - 1}")
    for ident in IDENTITIES:
        if ident.name == key:
            return ident
    raise unknown_name("identity", key, IDENTITY_NAMES)


@lru_cache(maxsize=64)
def face_crop(name: str) -> np.ndarray:
    """The identity's 25 x 25 grey crop, float in [0, 1]."""
    path = FACES_DIR / f"{name}.png"
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise FileNotFoundError(f"face crop missing: {path}")
    return img.astype(np.float64) / 255.0


def shading(crop: np.ndarray, size: int = TEXTURE_SIZE, mask_axes: tuple[float, float] = (
        0.75, 0.95), feather: float = 0.25, contrast: float = 1.0) -> np.ndarray:
    """Shading image ``(size, size)`` in [0, 1] from a grey face crop (1.0 = plain skin).

    The crop is divided by the median of its central (skin) region, its features deepened by
    ``contrast`` (``1 - contrast * (1 - f)``), upsampled, and blended to 1.0 outside an ellipse
    (semi-axes ``mask_axes`` of the half-size, soft edge ``feather``) so the crop's background
    and its square border never show on the head.
    """
    crop = np.asarray(crop, dtype=np.float64)
    h, w = crop.shape
    centre = crop[int(0.3 * h):int(0.7 * h), int(0.25 * w):int(0.75 * w)]
    f = crop / max(float(np.median(centre)), 1e-3)
    f = 1.0 - contrast * (1.0 - np.minimum(f, 1.0))
    f = cv2.resize(f.astype(np.float32), (size, size),
                   interpolation=cv2.INTER_CUBIC).astype(np.float64)
    yy, xx = np.mgrid[0:size, 0:size] / (size - 1) * 2.0 - 1.0
    r = np.hypot(xx / mask_axes[0], yy / mask_axes[1])
    a = np.clip((1.0 - r) / feather, 0.0, 1.0)
    return np.clip(a * f + (1.0 - a), 0.0, 1.0)


CUBE_FACES = ("right", "left", "up", "down", "front", "back")
"""MuJoCo's cube-texture faces, in the order of OpenGL's +x, -x, +y, -y, +z, -z."""


def cube_directions(size: int) -> dict[str, np.ndarray]:
    """Unit directions ``(size, size, 3)`` in the geom frame of every texel of each cube face.

    MuJoCo samples a cube texture on a sphere or an ellipsoid by the texel's direction on the
    *unit* sphere before the ellipsoid's scaling, with OpenGL's face conventions (``s`` along
    columns, ``t`` along rows, row 0 first) and the geom frame's axes as OpenGL's (measured:
    ``tests/test_faces.py``).
    """
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    tc, sc = np.meshgrid(c, c, indexing="ij")
    one = np.ones_like(sc)
    r = {"right": (one, -tc, -sc), "left": (-one, -tc, sc), "up": (sc, one, tc),
         "down": (sc, -one, -tc), "front": (sc, -tc, one), "back": (-sc, -tc, -one)}
    out = {}
    for face, (x, y, z) in r.items():
        v = np.stack([x, y, z], axis=-1)
        out[face] = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return out


@dataclass(frozen=True)
class FaceLayout:
    """Where the face crop lies on the head, seen from the front (orthographic), in m."""

    semi_axes: tuple[float, float, float] = (0.095, 0.078, 0.115)
    """The head ellipsoid's semi-axes (x forward, y left, z up): ``models/avatar.xml``."""
    width: float = 0.19
    """The crop's side on the head (the crop's edges are background: they fall off the head)."""
    z_center: float = -0.015
    """Height of the crop's centre relative to the head centre."""


def cube_faces(name: str, size: int = TEXTURE_SIZE, layout: FaceLayout = FaceLayout(),
               contrast: float = FEATURE_CONTRAST) -> dict[str, np.ndarray]:
    """The six ``(size, size, 3)`` uint8 images of the identity's head texture, by face.

    Each texel's point on the head ellipsoid is projected orthographically onto the frontal
    plane; front-facing points take the crop's shading there, the rest plain skin.
    """
    img = shading(face_crop(name), 4 * size, contrast=contrast)
    n = img.shape[0]
    out = {}
    for face, u in cube_directions(size).items():
        p = u * np.asarray(layout.semi_axes)
        # the viewer in front sees the person's left (+y) on the image's right
        col = ((p[..., 1] / layout.width) + 0.5) * n - 0.5
        row = ((layout.z_center - p[..., 2]) / layout.width + 0.5) * n - 0.5
        val = cv2.remap(img.astype(np.float32), col.astype(np.float32), row.astype(np.float32),
                        cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=1.0)
        val = np.where(p[..., 0] > 0.0, val, 1.0)
        g = np.round(np.clip(val, 0.0, 1.0) * 255.0).astype(np.uint8)
        out[face] = np.ascontiguousarray(np.repeat(g[..., None], 3, axis=-1))
    return out


def png_bytes(image: np.ndarray) -> bytes:
    """PNG encoding of an RGB uint8 image (for MJCF assets)."""
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(image[..., ::-1]))
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()
