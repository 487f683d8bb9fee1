"""Colour models learned for the scenario's own person at start-up, cached on disk.

``perception.color_model: auto`` (the default) learns the skin model from the run's own world
before the loop starts: the person is put in :data:`FRAMES` poses spread over its motion, the
eye cameras perception uses render only the avatar's geoms of the colour class (``skin``: the
hands and the face-textured head) with the scenario's pixel noise, and the segmentation labels
pick the pixels, less the darkest (the face's eyes and brows are not skin:
:func:`~humimic.perception.cues.learn_colors.trim_dark`)
(:func:`~humimic.perception.cues.learn_colors.frame_pixels`, as ``learn_colors`` does). A
Gaussian mixture (Ude eqs. 6-7) is fitted and tabulated
(:class:`~humimic.perception.cues.color_models.ColorLUT`). Since the renders come from the run's
own scene, the model sees the scenario's colours, face, lights, cameras and noise. The same
renders of the whole scene give the other pixels (clothes, shoes, room): the table is cleared
where they fall and no pixel of the class was seen -- or, for a learner that asks, where they
are more frequent than the class's own pixels, as shares of each (the 2-D hand tracker) or as
counts (Ude's blobs) (:func:`cut_background`), so the mixture's tails do not claim the scene's
own look-alikes (dark shoes under a very dark skin model, the dark-brown wood of lab_clutter
under a dark one).

Model and table are stored with :mod:`humimic.cache` under a hash of everything they depend on
(:func:`inputs`: the class's materials and textures, the lights, the cameras, the geoms' shapes,
the poses rendered, the learner's settings), so a second run with the same person and cameras
loads them (measured by ``benchmarks/bench_colors.py``). The noise of the renders is drawn from
a generator seeded by that hash: the same inputs give the same model on every run. Colour-model
files (an explicit ``color_model``) get their tables cached the same way.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from humimic import cache
from humimic.perception.cues.color_models import (
    ColorLUT,
    ColorModel,
    fit_color_model,
    load_color_model,
)
from humimic.perception.cues.learn_colors import frame_pixels, material_geoms, trim_dark

VERSION = 9
FRAMES = 8
"""Poses of the person rendered (spread evenly over the run)."""
COMPONENTS = 3
MAX_PIXELS = 10000
"""Pixels the mixture is fitted to (a random subset beyond this)."""
TOL = 1e-5
"""EM stops when the mean log-likelihood gains less (0.2 s instead of 1.5 s at 1e-7, the same
mixture to 0.3 % in mean log-likelihood)."""
MIN_PIXELS = 200
"""Fewer labelled pixels than this: the colour class is not in view of the cameras."""
NEGATIVES_PER_FRAME = 1 << 22
"""Other pixels taken per rendered frame for :func:`cut_background` (this many: all of them;
a sample of 6000 of 320x240 left 17 % of the shoes' pixels in bins it never hit)."""
LOOK_ALIKE_WARN = 1.0
"""A learned skin model whose :func:`look_alike_ratio` exceeds this (more look-alike pixels
than skin in the scene) is named in the run's warning line. Measured: ``static`` (the
learning renders; another noise draw within 10 %): the default person 0, a beige shirt [0.82,
0.70, 0.56] 0.41, [0.80, 0.66, 0.52] 2.2, a brown one [0.60, 0.45, 0.35] 3.7, a dark skin
[0.40, 0.27, 0.20] 0.19 in the lab and 1.7 in lab_clutter (its dark-brown posts). Ude &
Atkeson's blobs in ude_fig1_axes (seed 77, 3 s, right hand): default 0 (detected on 92 % of
visible frames, filtered RMSE 13 mm), the first beige 0.30 (92 %, 17 mm), the second 2.1
(28 %, 48 false frames: the shirt taken for the hand), the brown 3.1 (68 %, 116 mm), the dark
skin in lab_clutter 2.0 (2.5 %) -- all before the blobs' own cut (:data:`BACKGROUND_ODDS`:
0.03-0.13 and 89-92 %, no false frames)."""
MIN_BACKGROUND = 3
"""A bin is cleared only when at least this many sampled other pixels fall in it: a colour the
scene shows, not one noise pixel."""
BACKGROUND_RATIO = 1.0
"""The ratio of :func:`cut_background` a learner may ask for (``background_ratio``): a bin is
also cleared when its share of the other pixels exceeds this many times its share of the
class's pixels (a likelihood ratio: the colour is more typical of the scene than of the class).
By default only bins with no class pixel at all are cleared: a few shaded skin pixels kept the
bins of lab_clutter's dark-brown posts (51, 40, 30) under a dark skin (human.skin [0.40, 0.27,
0.20]), whose posterior stayed 0.80 (hand 0.96); at 1.0 the posts fall to 0.19, the scene's
pixels taken for skin from 7.2 to 1.8 %, 0.8 % of the skin's lost (default skin: no bin changes
in menezes_fig5_hand, static, wave, menezes_gest_far, fig12/13; 11 / 19 bins in
menezes_hand_people / menezes_fig9_leave_return, 0.1 / 0.2 % of the skin's pixels). Not the
default for every tracker: schmidt_table1_foveal's kpf lost 32 % of its frames with it (test
limit 10 %), not investigated."""
BACKGROUND_ODDS = 1.0
"""The ``odds`` of :func:`cut_background` a learner may ask for (``background_odds``): a bin
is also cleared when the scene's other pixels in it outnumber the class's own this many times
in the renders -- the class's posterior in the scene's own frequencies. (``ratio`` compares
shares, a likelihood ratio: the skin's ~7000 learning pixels weigh ~180 times the room's 1.2
million, so a colour both show stays the skin's.) Ude & Atkeson's blobs ask for it
(:mod:`humimic.perception.blobs.build`). Measured, ude_fig1_axes seed 77 in lab_clutter, skin
[0.40, 0.27, 0.20]: the posts' main bins hold 18-119 shaded skin pixels (0.3-1.7 % of the
skin's) and 900-1300 of the room's (0.1 %): ``ratio`` 1.0 kept them (54 % of the posts'
pixels cleared, 50 % still above posterior 0.5 in the run's images; the hand touches a post
in 51 of 60 sampled eye images, and blobs sat on the posts in 40 % of frames), ``odds`` 1.0
clears 98 % of them (3.5 % above 0.5) and 9 % of the skin's learning pixels (the hand's pixels
above 0.5: 99.9 -> 96 %). Right hand detected on 2.5 % -> 92 % of visible frames (``ratio``:
7 %); skins [0.45, 0.30, 0.22] / [0.30, 0.20, 0.15] seeds 5, 41, 77: 7-13 % / 2-24 % -> 92-94 %
/ 92 %, as in the plain lab (92 %); skin-like shirts in the lab (the :data:`LOOK_ALIKE_WARN`
cases): [0.80, 0.66, 0.52] 28 % (48 false frames) -> 89 % (0), [0.60, 0.45, 0.35] 68 % -> 91 %
(filtered RMSE 116 -> 25 mm). The default person: no bin changes in any ude scenario (lab or
lab_clutter), the same table."""


class NotInView(ValueError):
    """The colour class is not (enough) in view of the cameras to learn it."""


@dataclass(frozen=True)
class CachedLUT:
    lut: ColorLUT
    cached: bool
    """Loaded from the cache (False: learned or tabulated now, and stored)."""
    seconds: float
    digest: str


def sample_ticks(n_ticks: int, n_frames: int = FRAMES) -> np.ndarray:
    """``n_frames`` physics ticks spread evenly over ``n_ticks`` (first and last included)."""
    return np.unique(np.linspace(0, max(n_ticks - 1, 0), n_frames).round().astype(int))


def inputs(world, cameras: list[str], color_class: str, space: str, bits: int,
           ticks: np.ndarray, gains: tuple[float, ...] = (1.0,),
           background_ratio: float | None = None) -> tuple:
    """Everything a learned model depends on, for :func:`humimic.cache.key` (``gains`` and
    ``background_ratio`` only when not the defaults: the models learned without them keep
    their keys)."""
    m, d = world.scene.model, world.scene.data
    geoms = material_geoms(m, color_class)
    mats = np.unique(m.geom_matid[geoms])
    textures = [m.tex_data[m.tex_adr[t]:m.tex_adr[t] + m.tex_width[t] * m.tex_height[t]
                           * m.tex_nchannel[t]].tobytes()
                for t in np.unique(m.mat_texid[mats]) if t >= 0]
    lights = [getattr(m, f"light_{k}").tobytes() for k in
              ("active", "type", "ambient", "diffuse", "specular", "pos", "dir", "intensity",
               "attenuation", "castshadow")]
    head = m.vis.headlight
    cam_ids = [world.scene.camera(c) for c in cameras]
    specs = [s for s in world.eye_rig.specs if s.name in cameras]
    return (VERSION, mujoco.__version__, color_class, space, bits, FRAMES, COMPONENTS,
            MAX_PIXELS, TOL, repr(specs), m.cam_fovy[cam_ids].tobytes(),
            *(getattr(m, f"mat_{k}")[mats].tobytes() for k in
              ("rgba", "specular", "shininess", "emission", "reflectance", "texid")),
            *textures, *lights, head.ambient.tobytes(), head.diffuse.tobytes(),
            head.specular.tobytes(), int(head.active),
            *(getattr(m, f"geom_{k}")[geoms].tobytes() for k in ("type", "size", "pos", "quat")),
            m.body_pos.tobytes(), m.body_quat.tobytes(), d.qpos.tobytes(),
            world.gt.qpos[ticks].tobytes(), NEGATIVES_PER_FRAME, MIN_BACKGROUND,
            # the other pixels (cut_background): every surface's look and place
            m.mat_rgba.tobytes(), m.mat_texid.tobytes(), m.geom_rgba.tobytes(),
            m.geom_matid.tobytes(), m.geom_size.tobytes(), m.geom_type.tobytes(),
            m.geom_pos.tobytes(), m.geom_quat.tobytes(), m.tex_data.tobytes(),
            *(() if tuple(gains) == (1.0,) else ("gains", *map(float, gains))),
            *(() if background_ratio is None else ("background_ratio",
                                                   float(background_ratio))))


def digest_of(world, cameras: list[str], color_class: str = "skin", space: str = "rgb",
              bits: int = 6, gains: tuple[float, ...] = (1.0,),
              background_ratio: float | None = None,
              background_odds: float | None = None) -> str:
    """The cache key of the model :func:`learned_lut` would learn."""
    ticks = sample_ticks(world.n_ticks)
    return _with_odds(cache.key(*inputs(world, cameras, color_class, space, bits, ticks, gains,
                                        background_ratio)), background_odds)


def _with_odds(digest: str, background_odds: float | None) -> str:
    """The cache key of a table cut with ``background_odds`` from the fit keyed ``digest``."""
    if background_odds is None:
        return digest
    return cache.key(digest, "background_odds", float(background_odds))


def brightened(pixels: np.ndarray, gains: tuple[float, ...]) -> np.ndarray:
    """uint8 ``pixels (N, 3)`` as they look lit ``gain`` times as brightly, for each of
    ``gains`` in turn (``(len(gains) * N, 3)``), clipped at 255 as the camera saturates: the
    colours a surface takes in a pose the renders did not show -- a hand turned to the light
    or nearer the lamp (at 0.5-0.9 m from the eyes of menezes_gest_far, 40-60 % of its
    pixels beyond the model learned without them, with a pale skin or a brighter light)."""
    p = np.asarray(pixels, np.float64)
    return np.concatenate([np.clip(np.rint(p * g), 0, 255) for g in gains]).astype(np.uint8)


def bin_variance(bits: int) -> float:
    """Variance of a colour channel (in [0, 1]) uniform over one LUT bin of ``bits`` bits."""
    return (2.0 ** (8 - bits) / 255.0) ** 2 / 12.0


def learn_model(world, cameras: list[str], color_class: str, space: str,
                rng: np.random.Generator, ticks: np.ndarray, bits: int = 6,
                gains: tuple[float, ...] = (1.0,)
                ) -> tuple[ColorModel, np.ndarray, np.ndarray, np.ndarray]:
    """A colour model of ``color_class`` learned from the world's own renders; also the
    class's pixels it was fitted to (without the darkest: with them, the face's dark features
    would keep the shoes' bins) and the other pixels of the same renders, for
    :func:`cut_background`, and the class's pixels as rendered (before ``gains``), for
    :func:`look_alike_ratio`.

    Each component's covariance is at least one LUT bin wide (:func:`bin_variance` added to
    its diagonal): the LUT evaluates the density at bin centres, and a noiseless render gives
    components so narrow that they would fall between two centres and vanish from the table.
    The class's pixels are taken under each of ``gains`` (:func:`brightened`).
    """
    geoms = material_geoms(world.scene.model, color_class)
    noise = max((s.noise_std for s in world.eye_rig.specs if s.name in cameras), default=0.0)
    pos, neg = frame_pixels(world, cameras, ticks, geoms, noise, rng,
                            negatives_per_frame=NEGATIVES_PER_FRAME)
    pixels = trim_dark(np.concatenate(pos)) if pos else np.zeros((0, 3), np.uint8)
    plain = pixels
    if tuple(gains) != (1.0,) and len(pixels):
        pixels = brightened(pixels, gains)
    if len(pixels) < MIN_PIXELS:
        raise NotInView(f"only {len(pixels)} pixels of {color_class!r} in view of "
                        f"{', '.join(cameras)} in {len(ticks)} poses of the person")
    seen = pixels
    if len(pixels) > MAX_PIXELS:
        pixels = pixels[rng.choice(len(pixels), MAX_PIXELS, replace=False)]
    model = fit_color_model(pixels, space, COMPONENTS, rng, name=color_class, tol=TOL,
                            max_iter=100, reg_covar=bin_variance(bits))
    return model, seen, np.concatenate(neg) if neg else np.zeros((0, 3), np.uint8), plain


def bin_counts(px: np.ndarray, bits: int) -> np.ndarray:
    """Pixels ``px (N, 3)`` uint8 per bin of a ``bits``-bit colour table (:class:`ColorLUT`'s
    layout): ``(2^bits)^3`` counts."""
    q = np.asarray(px, np.uint8).reshape(-1, 3).astype(np.intp) >> (8 - bits)
    idx = (q[:, 0] << (2 * bits)) | (q[:, 1] << bits) | q[:, 2]
    return np.bincount(idx, minlength=1 << (3 * bits))


def look_alike_report(ratio: float | None, lost: float | None = None) -> dict:
    """A stage's metrics of the skin model it uses: ``skin_look_alike`` (the learned model's
    :func:`look_alike_ratio`; None for a model read from a file) and, above
    :data:`LOOK_ALIKE_WARN`, ``colour_warning`` (a line for the run's warning); given ``lost``
    (:func:`lost_fraction`), also ``skin_lost``, and above :data:`LOST_WARN` a warning."""
    out: dict = {"skin_look_alike": ratio}
    warn = []
    if ratio is not None and ratio > LOOK_ALIKE_WARN:
        warn.append(f"the scene shows {ratio:.2f} pixels of the skin's colours per skin pixel "
                    "(clothes or room of the skin's colour)")
    if lost is not None:
        out["skin_lost"] = lost
        if lost > LOST_WARN:
            warn.append(f"the skin's colour table lost {lost:.0%} of the skin's own pixels to "
                        "look-alike colours of the scene (clothes or room near the skin's "
                        "colour): blobs and stereo are less accurate")
    if warn:
        out["colour_warning"] = "; ".join(warn)
    return out


LOST_WARN = 0.05
"""A learned skin table that no longer takes more than this share of the skin's own pixels for
skin (:func:`lost_fraction`) is named in the run's warning line. Measured (ude_wave_tracking
seed 3): the default person 0.000; shirts [0.76, 0.60, 0.45] / [0.82, 0.70, 0.56] / [0.70,
0.52, 0.40] lose (see docs/ude_perception_notes.md) -- while :func:`look_alike_ratio`, which
counts what the cut table still confuses, stays at 0.11 for the first: the cut hid the
look-alikes by dropping skin."""


def lost_fraction(table: np.ndarray, bits: int, class_px: np.ndarray) -> float | None:
    """Share of the class's own pixels (``class_px (N, 3)`` uint8, as rendered) whose bin of
    ``table`` is not above the uniform outlier's density 1 (Ude eq. 6's test): the class's
    pixels a blob cannot claim, e.g. those :func:`cut_background` gave to a shirt of nearly
    the skin's colour. None without pixels."""
    counts = bin_counts(class_px, bits)
    n = int(counts.sum())
    if n == 0:
        return None
    return float(counts[np.asarray(table) <= 1.0].sum() / n)


def look_alike_ratio(table: np.ndarray, bits: int, class_px: np.ndarray,
                     other_px: np.ndarray) -> float | None:
    """Pixels of the scene's other surfaces (``other_px (N, 3)`` uint8: clothes, room) that
    ``table`` takes for the class (a bin density above the uniform outlier's 1, Ude eq. 6's
    test), per class pixel (``class_px``) it takes for the class, in the same renders; None
    when it takes none of the class. 0 for the default person; when it nears 1, as many
    pixels of something else look like the class as the class itself, and no colour table
    can tell them apart (:data:`LOOK_ALIKE_WARN`)."""
    hit = np.asarray(table) > 1.0
    n_class = int(bin_counts(class_px, bits)[hit].sum())
    if n_class == 0:
        return None
    return float(bin_counts(other_px, bits)[hit].sum() / n_class)


def cut_background(table: np.ndarray, bits: int, class_px: np.ndarray, other_px: np.ndarray,
                   min_other: int = MIN_BACKGROUND, ratio: float | None = None,
                   odds: float | None = None) -> np.ndarray:
    """A copy of a LUT ``table`` (``(2^bits)^3`` densities, :class:`ColorLUT` layout) with 0 in
    the bins where at least ``min_other`` of ``other_px (N, 3)`` uint8 fall and none of
    ``class_px`` -- or, with a ``ratio`` (:data:`BACKGROUND_RATIO`), where their share of
    ``other_px`` is more than ``ratio`` times the bin's share of ``class_px``; or, with
    ``odds`` (:data:`BACKGROUND_ODDS`), where they are more than ``odds`` times as many as the
    class's pixels in the bin: the model's tails where the scene's other surfaces are, and its
    own class was never seen (or seen less often), are not the class."""
    c_other, c_class = bin_counts(other_px, bits), bin_counts(class_px, bits)
    out = np.array(table, np.float32, copy=True)
    shown = c_other >= min_other
    cut = shown & (c_class == 0)
    if ratio is not None:
        n_class, n_other = max(len(class_px), 1), max(len(other_px), 1)
        cut |= shown & (c_other * n_class > ratio * c_class * n_other)
    if odds is not None:  # the class's posterior in the scene's own frequencies
        cut |= shown & (c_other > odds * c_class)
    out[cut] = 0.0
    return out


def _store(model: ColorModel, lut: ColorLUT) -> dict[str, np.ndarray]:
    return {"space": np.array(model.space), "name": np.array(model.name),
            "weights": model.weights, "means": model.means, "covs": model.covs,
            "table": lut.table,
            "look_alike": np.array(np.nan if lut.look_alike is None else lut.look_alike),
            "class_lost": np.array(np.nan if lut.class_lost is None else lut.class_lost)}


def _restore(stored: dict[str, np.ndarray] | None, bits: int) -> ColorLUT | None:
    if stored is None:
        return None
    try:
        model = ColorModel(str(stored["space"]), stored["weights"], stored["means"],
                           stored["covs"], str(stored["name"]))
        lut = ColorLUT(model, bits, stored["table"])
        ratio = float(stored["look_alike"])  # an entry from before it: learnt again, the same
        lost = float(stored["class_lost"])
    except (KeyError, ValueError):  # an entry of another layout: learn again
        return None
    lut.look_alike = None if np.isnan(ratio) else ratio
    lut.class_lost = None if np.isnan(lost) else lost
    return lut


def learned_lut(world, cameras: list[str], color_class: str = "skin", space: str = "rgb",
                bits: int = 6, gains: tuple[float, ...] = (1.0,),
                background_ratio: float | None = None,
                background_odds: float | None = None) -> CachedLUT:
    """The colour LUT of ``color_class`` for this world: from the cache, or learned from the
    world's renders of ``cameras`` (their pixels under each of ``gains``, :func:`brightened`)
    and stored; ``background_ratio``, ``background_odds``: :func:`cut_background`'s ``ratio``
    and ``odds``. The renders' noise and the fit are seeded without ``background_odds`` (it
    only cuts the table afterwards): a person whose table it leaves alone gets the same table
    with or without it. Raises :class:`NotInView`."""
    t0 = time.perf_counter()
    ticks = sample_ticks(world.n_ticks)
    fit_digest = digest_of(world, cameras, color_class, space, bits, gains, background_ratio)
    digest = _with_odds(fit_digest, background_odds)
    kind = f"colors-{color_class}"
    lut = _restore(cache.load(kind, digest), bits)
    cached = lut is not None
    if lut is None:
        rng = np.random.default_rng(int(fit_digest[:15], 16))
        model, seen, other, plain = learn_model(world, cameras, color_class, space, rng,
                                                ticks, bits, gains)
        lut = ColorLUT(model, bits, cut_background(ColorLUT(model, bits).table, bits, seen,
                                                   other, ratio=background_ratio,
                                                   odds=background_odds))
        lut.look_alike = look_alike_ratio(lut.table, bits, plain, other)
        lut.class_lost = lost_fraction(lut.table, bits, plain)
        cache.save(kind, digest, _store(model, lut))
    return CachedLUT(lut, cached, time.perf_counter() - t0, digest)


def file_lut(path: Path, bits: int = 6) -> CachedLUT:
    """The LUT of a colour-model file (its table cached under the file's content). Raises
    ``ValueError`` for a malformed file, ``FileNotFoundError`` for a missing one."""
    t0 = time.perf_counter()
    model = load_color_model(path)
    digest = cache.key(VERSION, "file", Path(path), bits)
    lut = _restore(cache.load("colors-file", digest), bits)
    cached = lut is not None
    if lut is None:
        lut = ColorLUT(model, bits)
        cache.save("colors-file", digest, _store(model, lut))
    return CachedLUT(lut, cached, time.perf_counter() - t0, digest)
