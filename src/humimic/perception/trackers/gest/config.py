"""Scenario configuration of Menezes et al.'s 3-D hand tracker GEST (sec. 6.1, Table 5)."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, PositiveFloat, model_validator

from humimic.scenario.base import Section, Vec3


class GestConfig(Section):
    """A hand as a free ellipsoid (9-D state: centre, yaw pitch roll, semi-axes) tracked by
    ICONDENSATION with an importance function from stereo skin blobs; defaults from Table 5."""

    kind: Literal["gest"] = "gest"
    hand: Literal["right", "left"] = "right"
    """The hand scored (the tracker follows whichever hand it locks on; the importance function
    proposes every hand-sized skin blob)."""
    cameras: tuple[str, str] | None = None
    """(left, right) eye cameras; default the rendered pair."""
    foveal: tuple[str, str] | None = None
    """(left, right) narrow cameras (e.g. ``[L_foveal, R_foveal]``, with ``cameras.which:
    both``) measured instead of ``cameras`` while the last estimate's hand lies inside both
    of their images (``foveal_margin_px``): 5.6x the wide eyes' focal length, 5.6x less
    depth per pixel of disparity. The wide pair (re-)initialises the filter and takes over
    when the hand leaves the narrow view; keep the hand in it with active gaze
    (``mimic.gaze.tracker``). Each frame's camera poses are the eyes' at that frame."""
    foveal_margin_px: float = Field(4.0, ge=0.0)
    """The hand's image (a circle of its longest semi-axis about its centre) must keep this
    far (px) from the narrow images' borders."""
    foveal_offset: bool = False
    """Correct the foveal pair's candidates by the estimate's silhouette offset as the wide
    pair's (:mod:`.tracker`). Off: with the eyes on the hand it images near both optical
    axes, where the offset is small and its estimate carries the orientation's error (50-80
    deg): menezes_gest_far with the person at 0.9 m (hand 0.5-0.9 m), seed 4, 19.3 mm RMS
    with it, 9.4 without; at 1.75 m, seeds 3-4, 8.6-9.5 with, 8.5 without. (In the wide
    pair, the hand off-axis, it helps: menezes_gest_reach 7.1 mm with, 8.8 without.) Those
    were with the estimate's own ellipsoid; the offset is now its orientation-free part
    (:mod:`.silhouette`)."""
    cue_radius_px: float | None = Field(None, gt=0.0)
    """Pixel budget of the cue images in the wide pair (speed, not in the paper; None, the
    default: always full resolution -- off because of the 0.9 m runs at the end of this note;
    the foveal pair's is ``foveal_cue_radius_px``):
    when the last estimate's hand image (radius ``fx`` times its longest semi-axis over its
    distance) is ``k >= 2`` times this, its shape, colour and skin cues are computed on the
    region of interest averaged over ``k x k`` blocks (intrinsics scaled to match: the hand
    images 12-24 px in radius with 12, as in the wide eyes at 0.45-0.9 m); the blobs stay full
    resolution (their centroids' disparity is the depth; searched at ``k`` times
    ``blob_subsample`` they cost 15.8 against 6.7 mm RMS on the foveal frames of
    menezes_gest_far at ``human.distance: 0.9``, seed 4). menezes_gest_far, seeds 3-5, 12
    px: the foveal frames as accurate at every distance (5.3-7.1 mm RMS against 6.5-7.2),
    the scenario's RMS unchanged at 1.75 m (8.7-8.8 mm) and 1.2 m (7.0-7.9 against
    7.2-8.1); a foveal frame's thread CPU 4.5-5.1 against 5.2-5.8 ms at 1.75 m, 4.7-4.8
    against 6.0-6.6 at 1.2 m (load 3-4; bench_trackers, 4 runs: 4.1-4.6 against 4.6-5.2 ms,
    the wide pair on the same frames 3.2-4.2). With the person at 0.9 m (hand 0.5-0.9 m,
    40-45 % of the frames foveal) the scenario's RMS is 10.7-19.6 mm with 12 or 20 px
    against 10.2-11.5 at full resolution, all of it on the wide pair's frames (13.2-24.6
    mm RMS on them against 12.3-13.9) -- within what the wide pair gives there at full
    resolution after any small change: ``sigma_s`` 1.52 or ``n_points`` 21, seeds 3-5,
    13.5-23.3 mm on them, 10.8-18.6 mm overall. That fragility was the blobs' (a lit hand's
    saturated pixels were no skin and bit into them, :mod:`.blobs`, ``skin_gains``) and the
    silhouette offset's (:mod:`.silhouette`): since, at 0.9 m, seeds 0-9, 5.8-6.2 mm at full
    resolution, 5.7-5.9 with ``n_points: 21``."""
    foveal_cue_radius_px: float | None = Field(12.0, gt=0.0)
    """``cue_radius_px`` for the frames measured in the foveal pair, where the hand images
    large (``fx`` 5.6x the wide eyes': radius ~40 px at 1.5 m, blocks of 3 with 12 px); None:
    full resolution. The wide pair's frames keep ``cue_radius_px``. Measured with 12 against
    None (menezes_gest_far, thread CPU of its foveal frames, the two interleaved, 12 repeats
    of 30 frames, load 3-6): 0.85-0.92x at 1.75 m (4.8 against 5.2 ms at load 6), 0.82-0.84x
    at 1.2 m (the blobs, a fifth of a foveal frame, are not decimated). menezes_gest_far,
    seeds 3-5, RMS (tracked fraction): 1.75 m 6.6-6.7 mm (0.99-1.0) either way; 1.5 m 3.4
    (1.0) against 3.4-3.9 (0.98-1.0); 1.2 m 4.4-4.5 (0.99-1.0) against 4.4-4.9
    (0.95-1.0); 0.9 m (39-51 % of the frames foveal), seeds 3-9, 5.7-6.0 (0.96-0.99)
    against 5.7-5.9 (0.96-0.98). menezes_gest_reach and fig11_gest_clutter: unchanged (no
    foveal pair)."""
    views: Literal[1, 2] = 1
    """Images the shape, colour and skin cues are evaluated in: 1 = the left image only (the
    paper), 2 = both (measured no better: 9.5-15 mm RMS either way on menezes_gest_reach at
    three distances, the stereo cue carrying the depth; 1.5x the cost)."""
    n_particles: int = Field(100, ge=1, le=20000)
    """Particles N."""
    alpha: float = Field(0.3, ge=0.0, le=1.0)
    """Share of particles drawn from the stereo importance function."""
    beta: float = Field(0.6, ge=0.0, le=1.0)
    """Share drawn from the dynamics (the rest from the prior)."""
    sigma_position: float = Field(0.02, gt=0.0, le=0.5)
    """Random-walk standard deviation of the centre per frame (m). Table 5: 1 cm (at 25 Hz);
    a reaching hand moves 5-10 mm per frame at 30 Hz, and with 1 cm the estimate trails it by
    4-6 cm (menezes_gest_reach: 57 mm RMS against 29 mm with 2 cm, with the earlier
    likelihood; with the sharp stereo cue both are within 1-2 mm of each other)."""
    sigma_angle_deg: float = Field(1.0, gt=0.0, le=90.0)
    """Random-walk standard deviation of yaw, pitch, roll per frame (deg); Table 5: 1."""
    sigma_axes: float = Field(1e-4, gt=0.0, le=0.05)
    """Random-walk standard deviation of the semi-axes per frame (m); Table 5: 1e-4."""
    reset: float = Field(0.05, gt=0.0, lt=1.0)
    """Probability per frame that the hand re-appears anywhere in the workspace, orientation
    and size kept (what lets a
    particle proposed by the importance function far from the others keep its weight)."""
    n_points: int = Field(20, ge=4, le=200)
    """Contour points N_p of the shape cue (eq. 3)."""
    sigma_s: float = Field(1.5, gt=0.0)
    """Shape-cue standard deviation (px, mean distance-transform value, eq. 3)."""
    edges: Literal["grey", "colour"] = "colour"
    """The shape cue's edges: Canny on the grey image (the paper) or on the colour gradient
    (the strongest channel's, as TBP's ``edges``): a dark hand over dark trousers or a blue
    shirt has almost no grey-level edge. menezes_gest_reach, skin (0.45, 0.30, 0.22), seed 9:
    tracked on 56 % of the in-view frames on grey edges, 77 % on colour; skin (0.55, 0.38,
    0.28): 49 / 97.5 %; (0.30, 0.20, 0.15): 100 % on colour; the same cost per frame."""
    sigma_c: float = Field(0.3, gt=0.0)
    """Colour-cue standard deviation (Bhattacharyya distance, eq. 6). Table 5 gives 0.03;
    with a hand 15-30 px wide the patch's histogram (a few dozen pixels in 32 bins per
    channel) is far from the reference even at the true pose (D ~ 0.3), and 0.03 makes the
    colour noise outweigh every other cue by hundreds of nats: 0.3 (Table 6's value)."""
    sigma_k: float = Field(0.3, gt=0.0)
    """Skin inside/outside cue's standard deviation (an addition, see
    :mod:`humimic.perception.trackers.gest.likelihood`)."""
    stereo_cue: bool = True
    """Use the triangulated skin blobs in the likelihood too (an addition, ibid.)."""
    stereo_outlier: float = Field(0.05, gt=0.0, le=1.0)
    """Weight of the uniform outlier (over both images) in the stereo cue."""
    skin_gains: tuple[PositiveFloat, ...] = Field((1.0, 1.15, 1.3), min_length=1, max_length=8)
    """The learned skin model (``perception.color_model: auto``) is fitted to the renders'
    skin pixels lit this many times as brightly too (clipped at 255,
    :func:`~humimic.perception.cues.auto_colors.brightened`): a hand nearer the lamp or
    turned to it is brighter than in any of the poses learned from, and its saturated pixels
    were no skin. menezes_gest_far with the person at 0.9 m, seed 3: skin (0.95, 0.78, 0.68)
    22.2 mm RMS with ``[1.0]``, 6.1 with these; ``lighting.diffuse: 0.75``, 16-19.5 against
    6.7 (seeds 1, 3)."""
    bins: Literal[8, 16, 32, 64] = 32
    kappa: float = Field(0.1, ge=0.0, le=1.0)
    """Reference-histogram update rate (eq. 13)."""
    axes: Vec3 = (0.045, 0.022, 0.08)
    """Nominal semi-axes (m) of the hand ellipsoid; the prior spans +-``axes_spread`` of it."""
    axes_spread: float = Field(0.2, ge=0.0, lt=1.0)
    workspace_low: Vec3 = (0.3, -0.8, 0.5)
    """Workspace box (robot base frame, m) of the prior over the centre."""
    workspace_high: Vec3 = (2.0, 0.8, 1.9)
    blob_size: tuple[float, float] = (0.04, 0.14)
    """Physical size range (m, sqrt of the blob's area times depth / focal length) of a skin
    blob the importance function accepts: a head is larger."""
    blob_subsample: int = Field(2, ge=1, le=4)
    """Subsampling of the skin mask the blobs are found in (sec. 4.2.2); each is then measured
    at full resolution in its box (:mod:`.blobs`). Measured at the subsampled resolution the
    nearest triangulated blob is 23 mm RMS from the hand, at full resolution 10 mm
    (menezes_gest_reach at 1.2 m; 73 against 16 mm at 1.5 m)."""
    blob_min_area_px: float = Field(16.0, ge=1.0)
    """Smallest skin blob (full-resolution px) the importance function looks at. A hand
    1.5 m from the wide eyes (f = 134 px) covers 28-37 px of skin, about 19 px at 2 m (the
    workspace's far end); with the earlier 40 px it was no candidate beyond ~1.3 m and the
    filter lost it: menezes_gest_reach at ``human.distance: 1.75`` (hand 1.24-1.56 m), seeds
    3-5, tracked on 58-62 % of the in-view frames, with 16 px on all of them."""
    border_px: float = Field(1.0, ge=0.0)
    """Skin blobs whose box comes closer than this (px) to an image border are cut by it (the
    hand leaving the view) and are not candidates."""
    max_epipolar_px: float = Field(4.0, gt=0.0)
    """Largest reprojection residual (px) of a left-right blob match."""
    blob_sigma_scale: float = Field(0.5, gt=0.0)
    """Blob position covariance (eq. 17) = ``scale^2`` times the blob box's inertia."""
    proposal: Literal["centroid", "blob"] = "centroid"
    """Position covariance of the importance function: ``blob``, eq. 17 with the blobs'
    inertia (the paper; ~10x wider in depth than the centroid's error), or ``centroid``,
    eq. 17 with an isotropic centroid error of ``proposal_px`` in each image, centred on the
    triangulated centroids corrected by the last estimate's silhouette offset."""
    proposal_px: float = Field(0.08, gt=0.0)
    """(Measured on menezes_gest_reach, 9 runs: 0.08 px gives 8.4-15.9 mm RMS, 0.15 px
    9.5-15.1, eq. 17 with the inertia ``blob`` 55-60 mm: particles spread over decimetres
    of depth, few where the stereo cue is.)"""
    position_floor: float = Field(0.001, ge=0.0)
    """Floor (m) added to the importance function's position standard deviation."""
    position: Literal["particles", "kalman"] = "kalman"
    """The estimate's centre. ``particles``: the weighted mean of the set (Table 1 step 7).
    ``kalman`` (a deviation, Rao-Blackwellised in spirit): the centre decoupled from
    orientation and size, its posterior given the stereo measurement (the nearest gated
    candidate plus the estimate's silhouette offset, eq. 17 covariance with
    ``centroid_px``) and the random walk, in closed form; orientation and size stay the
    particles'. With the weights collapsed (ESS 1-5) the particle mean is one draw from the
    posterior, not its mean (menezes_gest_reach, seeds 3-5: 8.4-9.1 mm RMS at 1.2 m against
    6.7 with ``kalman``; 13.2-15.5 against 11.8-12.2 at 1.5 m)."""
    roi: bool = True
    """Compute the cue images in a box around the candidates and the last estimate only."""
    cue_pad_px: float = Field(10.0, gt=0.0, le=30.0)
    """Margin (px of the cue images) of that box: the distance transform is exact up to this
    distance at every point of the unpadded box, and at least it beyond (an edge outside the
    box is not seen), a contour point that far off every edge being a misfit of 6.7
    ``sigma_s`` either way; was the transform's cap, 30 px (speed: the box 0.4-0.6x the
    pixels). fig11_gest_clutter, seeds 1-5: 7.8-9.8 mm RMS (mean 9.2, medians 3.5-5.6),
    tracked in view 0.56-0.59, against 8.2-10.9 (mean 9.3, medians 3.5-8.2) and 0.56-0.59 at
    30 px; menezes_gest_reach and _far unchanged (< 0.01 mm)."""
    orientation_sigma_deg: float = Field(90.0, gt=0.0)
    """Spread (deg) of the start density's orientation about the last estimate (the
    orientation is unknown when the filter (re-)starts)."""
    fresh_orientation: float = Field(0.5, ge=0.0, le=1.0)
    """Share of the importance function's draws whose orientation is uniform (explores
    orientations away from the current hypotheses); the rest continue the particles'."""
    centroid_px: float = Field(0.08, gt=0.0)
    """Standard deviation (px) of a blob centroid against the projected ellipse's centre (the
    stereo cue). Measured at the true pose on menezes_gest_reach (full-resolution blobs,
    0.7-1.3 m): 0.06-0.07 px per image (common part 0.05, left-right difference 0.08-0.10).
    A blob centroid's disparity error is what limits depth: 0.1 px is 9 mm at 0.9 m, 15 mm
    at 1.2 m."""
    init: Literal["raised", "any"] = "raised"
    """Which stereo candidate (re-)initialises the filter: ``raised``, the highest (the hand
    held up to the robot; the other hand hangs), or ``any`` (the whole importance function)."""
    gate_m: float = Field(0.15, gt=0.0)
    """While tracking, the importance function proposes only the candidates within this
    distance (m) of the last estimate (the other hand is not taken for this one when this one
    leaves the view)."""
    reacquire_m: float = Field(0.35, gt=0.0)
    """After a loss the filter re-starts only from a candidate within this distance (m) of
    where the hand was last tracked ..."""
    reacquire_frames: int = Field(90, ge=0)
    """... for this many frames; then from any (``init``)."""
    lost_px: float = Field(5.0, gt=0.0)
    """The estimate is ``lost`` when its mean contour distance to edges exceeds this (px) or
    it left the image; then the filter re-initialises from the importance function. The
    contour is the published estimate's, or a hand-sized ellipse in any pose at its centre
    (the orientation estimate is not judged: a dark hand 0.5-0.9 m away, its orientation
    75-105 deg off, was declared lost on 28-35 % of its frames, 3-9 mm off)."""
    lost_rel: float = Field(0.3, ge=0.0)
    """... or than this fraction of the hand's image radius (``fx`` times the longest
    semi-axis over its depth), if larger: the ellipsoid's misfit to the hand's outline grows
    with its image (3-5 px for a hand 40 px across in the foveal pair, 5-8 px on a fifth of
    its frames, which with 5 px alone were declared lost; a hand in the wide eyes beyond
    0.55 m keeps 5 px) ..."""
    lost_rim_odds: float = Field(2.0, ge=1.0, le=100.0)
    """... unless its rim still separates skin from background: the skin posterior just inside
    the ellipse at least this many times that just outside (:func:`.loss.rim_fits`, the 2-D
    hand tracker's ``lost_rim_odds``; a dark hand over a dark shirt has few grey-level edges:
    with ``edges: grey``, menezes_gest_reach with skin (0.55, 0.38, 0.28) is tracked on 49 %
    of the in-view frames, 7 mm RMS, against 34 % without the rim; ``edges: colour`` tracks
    it on 97.5 %). Relative, as the skin posterior's level on a hand depends on its skin
    tone; it replaces ``D_k = 1 - (inside - outside) <= 0.5`` (``lost_skin``), which declared
    a dark hand (skin (0.45, 0.30, 0.22); best rim inside 0.43-0.48, outside ~0) lost 2-11 mm
    from it: menezes_gest_reach seeds 0-4 10 -> 7 frames lost, menezes_gest_far at 0.9 m seed
    1 10 -> 7; the very dark (0.25, 0.16, 0.11) keeps its colour edges and was not; real
    losses (the hand hidden, leaving the view) unchanged (docs/menezes_notes.md)."""
    lost_m: float = Field(0.1, gt=0.0)
    """... or when no stereo candidate lies within this distance (m) of it ...
    """
    lost_frames: int = Field(3, ge=1)
    """... for this many frames in a row."""
    latency: float = Field(0.0, ge=0.0, le=1.0)
    """Declared processing latency (s) of the published pose."""

    @model_validator(mode="after")
    def _check(self) -> GestConfig:
        if self.alpha + self.beta > 1.0 + 1e-12:
            raise ValueError(f"alpha + beta must be <= 1, got {self.alpha} + {self.beta}")
        if any(h <= lo for lo, h in zip(self.workspace_low, self.workspace_high, strict=True)):
            raise ValueError("workspace_high must exceed workspace_low on every axis")
        if min(self.axes) <= 0:
            raise ValueError(f"axes must be > 0 m, got {self.axes}")
        if not 0 < self.blob_size[0] < self.blob_size[1]:
            raise ValueError(f"blob_size must be 0 < min < max, got {self.blob_size}")
        return self

    @property
    def sigma_walk(self) -> list[float]:
        a = math.radians(self.sigma_angle_deg)
        return [self.sigma_position] * 3 + [a] * 3 + [self.sigma_axes] * 3
