"""The textures of the wearable room (``models/room_sugiyama.xml``), made reproducibly.

Posters are natural images shipped with scikit-image (all CC0 or public domain; attribution in
``models/textures/README.md``); the bookshelf, the door, the drawers and the floor are drawn
here from a fixed seed. Reds are desaturated (:func:`suppress_red`): the Wii remote's marker is
the only strongly red thing in the room. The PNGs are committed in ``models/textures/`` so the
MJCF file compiles on its own; ``python -m humimic.world.textures`` rewrites them.

Textures are cheap to render on a CPU, geoms are not (llvmpipe pays ~30 us per drawn geom), so
the room's detail lives in a few large textured boxes.
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse

import cv2
import numpy as np

from humimic.paths import MODELS_DIR

TEXTURE_DIR = MODELS_DIR / "textures"
#: poster texture -> (scikit-image loader, output width, height in pixels)
POSTERS = {
    "astronaut": ("astronaut", 256, 256),
    "coffee": ("coffee", 300, 200),
    "chelsea": ("chelsea", 300, 200),
    "rocket": ("rocket", 200, 300),
    "camera": ("camera", 256, 256),
    "page": ("page", 384, 192),
    "hubble": ("hubble_deep_field", 300, 240),
    "retina": ("retina", 256, 256),
    "coins": ("coins", 320, 160),
    "ihc": ("immunohistochemistry", 256, 256),
    "grass": ("grass", 256, 180),
    "brick": ("brick", 256, 256),
    "cell": ("cell", 256, 256),
}
SEED = 11


def _rgb(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim == 2:
        image = np.repeat(image[..., None], 3, axis=2)
    if image.dtype != np.uint8:
        image = (255 * (image.astype(float) / max(float(image.max()), 1e-9))).astype(np.uint8)
    return image[..., :3]


def poster(loader: str, width: int, height: int) -> np.ndarray:
    """A scikit-image sample image, centre-cropped to ``width:height`` and resized (RGB)."""
    import skimage.data

    image = _rgb(getattr(skimage.data, loader)())
    h, w = image.shape[:2]
    aspect = width / height
    if w / h > aspect:
        cw = int(round(h * aspect))
        image = image[:, (w - cw) // 2:(w - cw) // 2 + cw]
    else:
        ch = int(round(w / aspect))
        image = image[(h - ch) // 2:(h - ch) // 2 + ch]
    return cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)


def bookshelf(rng: np.random.Generator, width: int = 320, height: int = 384,
              shelves: int = 5) -> np.ndarray:
    """The front of a bookshelf: dark boards and rows of book spines of random widths, heights,
    colours and tilts, with a pale label on some spines."""
    img = np.full((height, width, 3), (60, 40, 25), np.uint8)
    row = height // shelves
    for r in range(shelves):
        y_board = (r + 1) * row - 8
        x = 6
        while x < width - 12:
            w = int(rng.integers(7, 22))
            h = int(rng.integers(int(0.55 * row), row - 14))
            colour = tuple(int(c) for c in rng.integers(25, 235, 3))
            if rng.random() < 0.12:  # a gap
                x += w
                continue
            pts = np.array([[x, y_board], [x + w, y_board], [x + w, y_board - h],
                            [x, y_board - h]], np.int32)
            cv2.fillConvexPoly(img, pts, colour)
            if rng.random() < 0.5:
                ly = y_board - h + int(0.2 * h)
                cv2.rectangle(img, (x + 2, ly), (x + w - 3, ly + 6), (230, 225, 200), -1)
            x += w + 1
        cv2.rectangle(img, (0, y_board), (width - 1, y_board + 8), (95, 65, 40), -1)
    return img


def abstract_art(rng: np.random.Generator, width: int = 256, height: int = 256,
                 shapes: int = 40) -> np.ndarray:
    """Random coloured triangles and rectangles on a pale ground: corners everywhere, and no
    two posters alike."""
    img = np.full((height, width, 3), rng.integers(200, 245, 3), np.uint8)
    for _ in range(shapes):
        colour = tuple(int(c) for c in rng.integers(0, 255, 3))
        if rng.random() < 0.5:
            pts = rng.integers(0, [width, height], (3, 2)).astype(np.int32)
            cv2.fillConvexPoly(img, pts, colour)
        else:
            x0, y0 = rng.integers(0, [width - 10, height - 10])
            x1, y1 = x0 + rng.integers(8, width // 3), y0 + rng.integers(8, height // 3)
            cv2.rectangle(img, (int(x0), int(y0)), (int(x1), int(y1)), colour, -1)
    return img


def calendar(width: int = 224, height: int = 300) -> np.ndarray:
    """A month on a wall calendar: a picture band, a title, a 7 x 5 grid of numbered days."""
    img = np.full((height, width, 3), 250, np.uint8)
    cv2.rectangle(img, (0, 0), (width - 1, 90), (40, 90, 160), -1)
    cv2.circle(img, (60, 45), 28, (240, 200, 60), -1)
    cv2.putText(img, "MARCH", (70, 118), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (20, 20, 20), 2)
    cell_w, cell_h = (width - 14) // 7, (height - 140) // 5
    for k in range(35):
        i, j = k % 7, k // 7
        x, y = 7 + i * cell_w, 135 + j * cell_h
        cv2.rectangle(img, (x, y), (x + cell_w, y + cell_h), (120, 120, 120), 1)
        if 2 <= k < 33:
            cv2.putText(img, str(k - 1), (x + 3, y + 14), cv2.FONT_HERSHEY_PLAIN, 0.9,
                        (200, 30, 30) if i == 6 else (30, 30, 30), 1)
    return img


def banner(rng: np.random.Generator, width: int = 768, height: int = 80) -> np.ndarray:
    """A long banner of words in blocks of colour."""
    img = np.full((height, width, 3), (30, 60, 110), np.uint8)
    words = ("WEARABLE", "ROBOT", "CONTROL", "INTERFACE", "SLAM", "CAMERA", "INERTIAL")
    x = 10
    while x < width - 60:
        word = words[int(rng.integers(len(words)))]
        colour = tuple(int(c) for c in rng.integers(120, 255, 3))
        cv2.putText(img, word, (x, 52), cv2.FONT_HERSHEY_DUPLEX, 1.0, colour, 2)
        x += 22 * len(word) + 20
    return img


def door(width: int = 192, height: int = 384) -> np.ndarray:
    """A panelled wooden door with a dark frame and a brass handle."""
    img = np.full((height, width, 3), (150, 105, 65), np.uint8)
    cv2.rectangle(img, (0, 0), (width - 1, height - 1), (70, 45, 30), 10)
    for y0, y1 in ((30, 170), (200, 360)):
        cv2.rectangle(img, (28, y0), (width - 28, y1), (110, 75, 45), 4)
        cv2.rectangle(img, (38, y0 + 10), (width - 38, y1 - 10), (165, 118, 75), -1)
    cv2.rectangle(img, (width - 30, 180), (width - 14, 196), (210, 180, 60), -1)
    return img


def drawers(width: int = 320, height: int = 192, rows: int = 3, cols: int = 2) -> np.ndarray:
    """The front of a sideboard: light grey drawers with dark gaps and handles."""
    img = np.full((height, width, 3), (40, 40, 45), np.uint8)
    dw, dh = width // cols, height // rows
    for i in range(cols):
        for j in range(rows):
            x0, y0 = i * dw + 4, j * dh + 4
            cv2.rectangle(img, (x0, y0), (x0 + dw - 8, y0 + dh - 8), (200, 200, 195), -1)
            cx, cy = x0 + dw // 2 - 4, y0 + dh // 2 - 4
            cv2.rectangle(img, (cx - 18, cy - 3), (cx + 18, cy + 3), (60, 60, 65), -1)
    return img


def floor(rng: np.random.Generator, size: int = 256, planks: int = 6) -> np.ndarray:
    """Wooden floor planks of slightly different tones with staggered joints and grain."""
    img = np.zeros((size, size, 3), np.uint8)
    pw = size // planks
    for k in range(planks):
        tone = np.array([120, 85, 55]) * rng.uniform(0.8, 1.15)
        img[:, k * pw:(k + 1) * pw] = tone
        grain = rng.normal(0, 6, (size, 1, 1)) * np.ones((1, pw, 1))
        img[:, k * pw:(k + 1) * pw] = np.clip(img[:, k * pw:(k + 1) * pw] + grain, 0, 255)
        cv2.line(img, (k * pw, 0), (k * pw, size - 1), (50, 35, 25), 2)
        j = int(rng.integers(20, size - 20))
        cv2.line(img, (k * pw, j), ((k + 1) * pw, j), (50, 35, 25), 2)
    return img


#: Hue band (degrees, both ends of the circle) kept desaturated in the room: the Wii remote's
#: marker is the only strongly red thing (Sugiyama & Miura extract it as the largest region of
#: hue 0-20 deg), as in their lab.
RED_HUES_DEG = (25.0, 335.0)
#: Largest saturation (of 255) left in that band.
RED_MAX_SATURATION = 90


def suppress_red(image: np.ndarray) -> np.ndarray:
    """``image`` (RGB) with the saturation of reddish pixels (hue below 25 deg or above 335
    deg) capped at :data:`RED_MAX_SATURATION`."""
    hsv = cv2.cvtColor(image, cv2.COLOR_RGB2HSV)  # OpenCV hue: degrees / 2
    h, sat = hsv[..., 0], hsv[..., 1]
    red = (h <= RED_HUES_DEG[0] / 2) | (h >= RED_HUES_DEG[1] / 2)
    hsv[..., 1] = np.where(red, np.minimum(sat, RED_MAX_SATURATION), sat)
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)


def all_textures() -> dict[str, np.ndarray]:
    """Every texture of the room by file stem (RGB uint8), red suppressed."""
    rng = np.random.default_rng(SEED)
    out = {name: poster(*spec) for name, spec in POSTERS.items()}
    out["books_a"] = bookshelf(rng)
    out["books_b"] = bookshelf(rng, width=384, height=320, shelves=4)
    out["door"] = door()
    out["drawers"] = drawers()
    out["parquet"] = floor(rng)
    for name in ("art_a", "art_b", "art_c", "art_d"):
        out[name] = abstract_art(rng)
    out["calendar"] = calendar()
    out["banner"] = banner(rng)
    return {name: suppress_red(image) for name, image in out.items()}


def write_textures(directory=TEXTURE_DIR) -> list:
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, image in all_textures().items():
        path = directory / f"{name}.png"
        cv2.imwrite(str(path), cv2.cvtColor(image, cv2.COLOR_RGB2BGR),
                    [cv2.IMWRITE_PNG_COMPRESSION, 9])
        paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m humimic.world.textures",
                                description="Write the wearable room's textures.")
    p.add_argument("--out", default=str(TEXTURE_DIR), help="directory (default: models/textures)")
    args = p.parse_args(argv)
    from pathlib import Path

    for path in write_textures(Path(args.out)):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
