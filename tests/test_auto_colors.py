"""Colour models learned for the scenario's own person (``perception.color_model: auto``)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from humimic.paths import SCENARIOS_DIR
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.auto_colors import (
    brightened,
    digest_of,
    file_lut,
    inputs,
    learned_lut,
    sample_ticks,
)
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.cues.learn_colors import frame_pixels, material_geoms
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.world.world import World

DARK = "human.skin=[0.45,0.30,0.22]"


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("HUMIMIC_CACHE_DIR", str(tmp_path))
    return tmp_path


def _world(*overrides: str) -> World:
    scenario = load_scenario(SCENARIOS_DIR / "static.yaml", list(overrides), duration=0.2)
    return World(scenario, Rngs(scenario.seed))


def _skin_and_rest(world, noise: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Skin pixels and other pixels of the full scene (an independent labelling)."""
    geoms = material_geoms(world.scene.model, "skin")
    pos, neg = frame_pixels(world, world.eye_cameras, np.array([0]), geoms, noise,
                            np.random.default_rng(3), negatives_per_frame=20000)
    return np.concatenate(pos), np.concatenate(neg)


def test_skin_class_includes_the_face():
    world = _world()
    try:
        m = world.scene.model
        names = {m.geom(g).name for g in material_geoms(m, "skin")}
    finally:
        world.close()
    assert names == {"human/head", "human/r_hand", "human/l_hand"}


def test_dark_skin_learned_and_cached(cache_dir):
    world = _world(DARK)
    try:
        cams = world.eye_cameras
        first = learned_lut(world, cams)
        second = learned_lut(world, cams)
        skin, rest = _skin_and_rest(world)
    finally:
        world.close()
    assert not first.cached and second.cached and first.digest == second.digest
    assert len(list(cache_dir.glob("colors-skin-*.npz"))) == 1
    np.testing.assert_array_equal(first.lut.table, second.lut.table)
    # the learned model finds this person's skin and little else (measured 0.957 / 0.001; the
    # skin's darkest pixels, eyes, brows and deep shade, share bins with the scene's dark
    # surfaces and are cut: 0.998 before cut_background)
    assert (second.lut.lookup(skin) > 1.0).mean() >= 0.92
    assert (second.lut.lookup(rest) > 1.0).mean() <= 0.01
    # the shipped model, learned for the default skin, misses most of it (measured 0.22)
    shipped = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))
    assert (shipped.lookup(skin) > 1.0).mean() <= 0.45


def test_noiseless_renders_give_a_usable_table(cache_dir):
    """Without pixel noise the skin has few distinct colours: the mixture must still cover
    them at the table's bin centres (measured 1.0; without the bin-wide floor on the
    covariances mimic_tracked_wave detected nothing)."""
    world = _world("cameras.noise_std=0.0")
    try:
        lut = learned_lut(world, world.eye_cameras).lut
        skin, rest = _skin_and_rest(world, noise=0.0)
    finally:
        world.close()
    assert (lut.lookup(skin) > 1.0).mean() >= 0.97
    assert (lut.lookup(rest) > 1.0).mean() <= 0.01
    # shading scales skin along a ray through black: without trim_dark the face's eyes and
    # brows pull the mixture down that ray and black frames look like skin (density 1.4 at
    # a fraction of 0.3; measured 1e-5 at 0.6)
    assert lut.lookup(np.zeros((1, 3), np.uint8))[0] < 0.01


def test_cache_key_follows_the_person(cache_dir):
    a, b = _world(), _world("human.skin=[0.72,0.52,0.40]")
    try:
        da, db = digest_of(a, a.eye_cameras), digest_of(b, b.eye_cameras)
        assert learned_lut(a, a.eye_cameras).digest == da
        # lights changed in the compiled model change the key too
        a.scene.model.light_diffuse[:] *= 0.5
        dl = digest_of(a, a.eye_cameras)
        # a learner's background ratio (hand2d's) is its own table; without one the key is
        # the one learned before the option existed (nothing in the inputs names it)
        dr = digest_of(a, a.eye_cameras, background_ratio=1.0)
        assert digest_of(a, a.eye_cameras, background_ratio=None) == dl
        plain = inputs(a, a.eye_cameras, "skin", "rgb", 6, sample_ticks(a.n_ticks))
    finally:
        a.close()
        b.close()
    assert len({da, db, dl, dr}) == 4
    assert "background_ratio" not in repr(plain)


def test_file_lut_cached_by_content(cache_dir, tmp_path):
    first, second = file_lut(DEFAULT_COLOR_MODEL), file_lut(DEFAULT_COLOR_MODEL)
    assert not first.cached and second.cached
    np.testing.assert_array_equal(first.lut.table, ColorLUT(first.lut.model).table)


def test_sample_ticks_cover_the_run():
    np.testing.assert_array_equal(sample_ticks(841, 5), [0, 210, 420, 630, 840])
    np.testing.assert_array_equal(sample_ticks(1, 8), [0])


def test_cut_background_clears_only_unseen_bins_the_scene_shows():
    """Against a table indexed by hand (ColorLUT's own index): bins with >= 3 other pixels and
    no class pixel are cleared; a bin shared with the class, or with too few others, is kept."""
    from humimic.perception.cues.auto_colors import cut_background

    bits = 6
    table = np.full(64**3, 5.0, np.float32)
    skin = np.array([[200, 150, 120]] * 10, np.uint8)
    shoe = np.array([[25, 20, 17]] * 4, np.uint8)            # 4 others, no skin: cleared
    shared = np.array([[201, 151, 121]] * 9, np.uint8)       # others in a skin bin: kept
    speck = np.array([[90, 90, 200]] * 2, np.uint8)          # 2 others: kept
    out = cut_background(table, bits, skin, np.concatenate([shoe, shared, speck]))

    def bin_of(rgb):
        r, g, b = (c // 4 for c in rgb)
        return r * 64 * 64 + g * 64 + b

    assert out[bin_of((25, 20, 17))] == 0.0
    assert out[bin_of((200, 150, 120))] == 5.0 and out[bin_of((90, 90, 200))] == 5.0
    assert np.count_nonzero(out == 0.0) == 1 and table.min() == 5.0  # a copy


def test_very_dark_skin_model_does_not_claim_the_shoes(cache_dir):
    """The very dark skin model's tails reach the dark shoes (rendered ~(25, 20, 17)): the
    learned table is cleared where the scene's own shoes fall (uncut, a blob was tracked on a
    foot at 2 m and named left_hand on every frame)."""
    scenario = load_scenario(SCENARIOS_DIR / "ude_wave_tracking.yaml",
                             ["human.skin=[0.30,0.20,0.15]", "human.distance=2.0"], duration=0.2)
    world = World(scenario, Rngs(scenario.seed))
    try:
        lut = learned_lut(world, world.eye_cameras).lut
        geoms = material_geoms(world.scene.model, "shoes")
        shoes, _ = frame_pixels(world, world.eye_cameras, np.array([0]), geoms, 2.0,
                                np.random.default_rng(5))
        skin, _ = _skin_and_rest(world)
        shoes = np.concatenate(shoes)
        assert len(shoes) > 50
        uncut = ColorLUT(lut.model, lut.bits)  # the mixture's own table
        assert (uncut.lookup(shoes) > 1.0).mean() >= 0.5  # the tails claim them: measured 0.81
        assert (lut.lookup(shoes) > 1.0).mean() <= 0.15  # measured 0.07
        # the skin itself is kept (its darkest pixels, eyes and brows, are not learned as skin):
        # measured 0.947 of all its pixels (uncut 0.988)
        assert (lut.lookup(skin) > 1.0).mean() >= 0.9
    finally:
        world.close()


def test_brightened_pixels_saturate_as_opencvs_scaling():
    rng = np.random.default_rng(3)
    px = rng.integers(0, 256, (500, 3), dtype=np.uint8)
    got = brightened(px, (1.0, 1.15, 1.3))
    want = np.concatenate([cv2.convertScaleAbs(px, alpha=g) for g in (1.0, 1.15, 1.3)])
    assert got.dtype == np.uint8 and got.shape == (1500, 3)
    assert np.abs(got.astype(int) - want).max() <= 1        # rounding of halves may differ
    assert (got[1000:] == 255).mean() > 0.2                  # a bright third saturates


def test_cut_background_clears_bins_the_scene_fills_more_than_the_class():
    """A bin that a few shaded skin pixels share with a large surface of the scene (a dark
    skin's shade and lab_clutter's dark-brown posts) is cleared when its share of the other
    pixels is more than ``ratio`` times its share of the skin's; the skin's own bin, which
    some other pixels share, stays."""
    from humimic.perception.cues.auto_colors import cut_background

    bits = 6
    table = np.full(64**3, 5.0, np.float32)
    skin = np.array([[200, 150, 120]] * 95 + [[52, 40, 30]] * 5, np.uint8)   # 5 % shade
    other = np.array([[53, 41, 29]] * 900 + [[201, 151, 121]] * 100, np.uint8)  # post 90 %

    def bin_of(rgb):
        r, g, b = (c // 4 for c in rgb)
        return r * 64 * 64 + g * 64 + b

    out = cut_background(table, bits, skin, other, ratio=1.0)    # 0.90 > 0.05
    assert out[bin_of((52, 40, 30))] == 0.0 and out[bin_of((200, 150, 120))] == 5.0
    kept = cut_background(table, bits, skin, other, ratio=20.0)  # 0.90 < 20 x 0.05
    assert kept[bin_of((52, 40, 30))] == 5.0
    assert np.count_nonzero(out == 0.0) == 1 and np.count_nonzero(kept == 0.0) == 0
    # without a ratio (the default) the shared bin stays: a class pixel fell in it
    assert np.count_nonzero(cut_background(table, bits, skin, other) == 0.0) == 0


def test_look_alike_ratio_counts_scene_pixels_in_class_bins():
    """Against a hand count: other pixels in bins above the outlier's 1, per class pixel in
    them."""
    from humimic.perception.cues.auto_colors import look_alike_ratio

    table = np.zeros(64**3, np.float32)
    skin = np.array([[200, 150, 120]] * 8 + [[40, 40, 200]] * 2, np.uint8)
    table[(200 // 4) * 4096 + (150 // 4) * 64 + 120 // 4] = 3.0     # the skin's bin only
    shirt = np.array([[202, 149, 121]] * 12 + [[10, 200, 10]] * 30, np.uint8)
    assert look_alike_ratio(table, 6, skin, shirt) == 12 / 8
    assert look_alike_ratio(np.zeros_like(table), 6, skin, shirt) is None


def test_skin_coloured_shirt_is_measured_as_a_look_alike(cache_dir):
    """The learned model's look-alike ratio against one measured on independent renders
    (another noise draw): 0 for the default person; a shirt close to the skin's colour gives
    the ratio its own renders give (measured 2.22 / 2.10; learned with brightened copies of
    the skin (GEST's gains) it is checked the same way: the copies are not counted). An entry
    stored without the ratio is learnt again: the same table, the ratio added."""
    from humimic import cache

    for shirt, low, high, gains in ((None, 0.0, 0.0, (1.0,)),
                                    ("[0.80,0.66,0.52]", 1.0, 4.0, (1.0,)),
                                    ("[0.80,0.66,0.52]", 1.0, 4.0, (1.0, 1.15, 1.3))):
        world = _world(*([f"human.shirt={shirt}"] if shirt else []))
        try:
            got = learned_lut(world, world.eye_cameras, gains=gains)
            pos, neg = frame_pixels(world, world.eye_cameras, np.array([0, 60]),
                                    material_geoms(world.scene.model, "skin"), 2.0,
                                    np.random.default_rng(3), negatives_per_frame=1 << 22)
            skin, rest = np.concatenate(pos), np.concatenate(neg)   # every pixel
            path = cache.path("colors-skin", got.digest)
            stored = dict(np.load(path))
            stored.pop("look_alike")
            cache.save("colors-skin", got.digest, stored)
            again = learned_lut(world, world.eye_cameras, gains=gains)
        finally:
            world.close()
        lut = got.lut
        want = (lut.lookup(rest) > 1.0).sum() / (lut.lookup(skin) > 1.0).sum()
        assert low <= lut.look_alike <= high and low <= want <= high, (lut.look_alike, want)
        assert abs(lut.look_alike - want) <= 0.15 * max(want, 0.1)
        assert not again.cached and again.lut.look_alike == lut.look_alike
        np.testing.assert_array_equal(again.lut.table, lut.table)


def test_cut_background_odds_compare_pixel_counts_not_shares():
    """``odds`` clears a bin where the other pixels outnumber the class's (counted by hand):
    a post's colour that 40 shaded skin pixels share with 60 of the room's is cleared although
    it is 40 % of the skin's pixels and 0.6 % of the room's (``ratio`` 1.0 keeps it); a bin
    where the skin is the more frequent stays."""
    from humimic.perception.cues.auto_colors import cut_background

    bits = 6
    table = np.full(64**3, 5.0, np.float32)
    skin = np.array([[200, 150, 120]] * 60 + [[52, 40, 30]] * 40, np.uint8)
    other = np.array([[53, 41, 29]] * 60 + [[201, 151, 121]] * 50 + [[10, 200, 10]] * 9890,
                     np.uint8)

    def bin_of(rgb):
        r, g, b = (c // 4 for c in rgb)
        return r * 64 * 64 + g * 64 + b

    post, lit, green = bin_of((52, 40, 30)), bin_of((200, 150, 120)), bin_of((10, 200, 10))
    by_odds = cut_background(table, bits, skin, other, odds=1.0)      # 60 > 40; 50 < 60
    assert by_odds[post] == 0.0 and by_odds[lit] == 5.0 and by_odds[green] == 0.0
    assert np.count_nonzero(by_odds == 0.0) == 2
    kept = cut_background(table, bits, skin, other, odds=2.0)         # 60 < 2 x 40
    assert kept[post] == 5.0 and np.count_nonzero(kept == 0.0) == 1
    by_ratio = cut_background(table, bits, skin, other, ratio=1.0)   # 0.006 < 0.4
    assert by_ratio[post] == 5.0


def test_background_odds_leaves_the_default_person_alone(cache_dir):
    """The cut with ``background_odds`` is a separate cache entry, its fit seeded as the one
    without: for the default person (no colour of the scene outnumbers the skin's) the table
    is the same (measured: 0 bins changed in every ude scenario, lab and lab_clutter)."""
    world = _world("room=lab_clutter")
    try:
        plain = learned_lut(world, world.eye_cameras)
        odds = learned_lut(world, world.eye_cameras, background_odds=1.0)
    finally:
        world.close()
    assert odds.digest != plain.digest and not odds.cached
    np.testing.assert_array_equal(odds.lut.table, plain.lut.table)


def test_lost_fraction_counts_class_pixels_the_table_does_not_take():
    from humimic.perception.cues.auto_colors import lost_fraction

    table = np.zeros(1 << 18, np.float32)
    skin = np.array([[200, 150, 120]] * 6 + [[40, 40, 200]] * 2, np.uint8)
    table[(50 << 12) | (37 << 6) | 30] = 5.0  # the first colour's 6-bit bin
    assert lost_fraction(table, 6, skin) == 2 / 8
    table[(10 << 12) | (10 << 6) | 50] = 1.0  # density 1: not above the outlier's
    assert lost_fraction(table, 6, skin) == 2 / 8
    assert lost_fraction(table, 6, skin[:0]) is None


def test_skin_lost_to_a_skin_like_shirt_is_measured_and_warned(cache_dir):
    """The share of the skin's own pixels the cut table no longer takes, against one counted
    on independent renders (another noise draw): ~0 for the default person, 0.17 for a shirt
    of nearly the skin's colour (whose look-alike ratio, 0.13, stays under its warning: the
    cut hid the look-alikes by dropping skin); the run's warning names it."""
    from humimic.perception.cues.auto_colors import LOST_WARN, look_alike_report
    from humimic.perception.cues.learn_colors import trim_dark

    for shirt, low, high in ((None, 0.0, 0.002), ("[0.76,0.60,0.45]", 0.1, 0.3)):
        world = _world(*([f"human.shirt={shirt}"] if shirt else []))
        try:
            lut = learned_lut(world, world.eye_cameras, background_odds=1.0).lut
            pos, _ = frame_pixels(world, world.eye_cameras, np.array([0, 60]),
                                  material_geoms(world.scene.model, "skin"), 2.0,
                                  np.random.default_rng(3), negatives_per_frame=1)
        finally:
            world.close()
        want = float((lut.lookup(trim_dark(np.concatenate(pos))) <= 1.0).mean())
        assert low <= lut.class_lost <= high and low <= want <= high, (lut.class_lost, want)
        assert abs(lut.class_lost - want) <= 0.2 * max(want, 0.01)
        report = look_alike_report(lut.look_alike, lut.class_lost)
        assert report["skin_lost"] == lut.class_lost
        assert ("colour_warning" in report) == (lut.class_lost > LOST_WARN) == bool(shirt)
    assert "lost 1" in report["colour_warning"]  # "lost 17% of the skin's own pixels"
