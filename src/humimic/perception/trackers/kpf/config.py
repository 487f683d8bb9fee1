"""Scenario config of Schmidt, Fritsch & Kwolek's kernel-particle-filter tracker (``kind: kpf``).

Defaults are the paper's experiment (sec. 6): cues torso {edge, colour}, upper arm {edge,
ridge, colour}, forearm {edge, ridge}, hand and head {skin}; M_E = 20, M_R = 30, B_arm = 3,
B_torso = 4; D_arm = [22, 20, 35, 25] deg (shoulder SFE, SAA, HR, elbow; the text is garbled
around the degree signs, we read the four numbers as degrees), D_torso 2 deg and 3 cm (the
paper: "1-3 deg" and "1-5 cm"); h0 = D, h = 0.8^i h0, the mode window 0.25 D; the motion model's
noise 0.25 D.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from humimic.scenario.base import Section

#: One arm DOF's propagation extent (deg).
ArmExtent = Annotated[float, Field(gt=0.0, le=180.0)]


class KpfCues(Section):
    """Cues per limb type (Schmidt sec. 6)."""

    torso: list[Literal["edge", "ridge", "colour"]] = Field(
        default_factory=lambda: ["edge", "colour"])
    upper_arm: list[Literal["edge", "ridge", "colour"]] = Field(
        default_factory=lambda: ["edge", "ridge", "colour"])
    forearm: list[Literal["edge", "ridge"]] = Field(default_factory=lambda: ["edge", "ridge"])
    hand: list[Literal["skin"]] = Field(default_factory=lambda: ["skin"])
    head: list[Literal["skin"]] = Field(default_factory=lambda: ["skin"])


class KpfSigma(Section):
    """Eq. 9's standard deviations of each cue's cost: the floor under the spread of the
    responses over the particles (``sigma_from_spread``), or the value itself."""

    edge: float = Field(0.15, gt=0.0, le=10.0)
    ridge: float = Field(0.3, gt=0.0, le=10.0)
    colour: float = Field(0.1, gt=0.0, le=10.0)
    skin: float = Field(0.3, gt=0.0, le=10.0)


class KpfConfig(Section):
    """Kernel particle filter 14-DOF upper-body tracker (Schmidt sec. 5.2)."""

    kind: Literal["kpf"] = "kpf"
    camera: str | None = None
    """Eye camera it watches (default: the first rendered one)."""
    filter: Literal["kpf", "condensation"] = "kpf"
    """``kpf``: mean shift and mixed propagation; ``condensation``: plain CONDENSATION (random
    walk of the same extent, weighted mean), the paper's baseline."""
    n_particles: int = Field(1000, gt=0, le=20000)
    iterations: int = Field(3, gt=0, le=20)
    """Maximum mean-shift iterations per frame."""
    D_arm_deg: list[ArmExtent] = Field(default_factory=lambda: [22.0, 20.0, 35.0, 25.0],
                                   min_length=4, max_length=4)
    """Propagation extent per arm DOF: SFE, SAA, HR, EB (deg)."""
    D_torso_deg: float = Field(2.0, gt=0.0, le=45.0)
    D_torso_m: float = Field(0.03, gt=0.0, le=0.5)
    D_rate: float = Field(7.5, gt=0.0, le=240.0)
    """The frame rate (Hz) the extents D are for (the paper's 7.5 Hz); at another camera rate
    they scale by ``sqrt(D_rate / rate)``, a random walk's spread over the same time."""
    shrink: float = Field(0.8, gt=0.0, lt=1.0)
    """Bandwidth factor per iteration, h = shrink^i D."""
    window: float = Field(0.25, gt=0.0, le=2.0)
    """Dominant-mode window, as a fraction of D."""
    motion_noise: float = Field(0.25, gt=0.0, le=1.0)
    """The motion model's noise extent, as a fraction of D."""
    torso_velocity: bool = True
    """The linear motion model's velocity (the last two best modes' difference) on the torso's
    DOFs too, as the paper; False (our extension): on the arms only, the torso's motion-model
    particles predicted in place. A standing person's torso hardly moves, so its velocity from
    two modes is the estimate's frame-to-frame jitter, and feeding it forward integrates that
    jitter into a drift the weakly observed torso depth does not stop. Measured (18 s of
    side pointing, three gestures, (1000, 3), seeds 1-4 and 31): the paper's config's torso
    50-340 mm off in the third gesture, 7-35 mm without; Table 1's ``kpf`` (torso prior on)
    mean wrist error 114 -> 85 mm, lost 16 % -> 7 % of frames; Table 1 (7.5 s, seeds 0-4)
    side 87 -> 71 and angular 207 -> 202 mm at (1000, 3), 124 -> 74 and 244 -> 182 at
    (150, 2). On in Table 1's ``kpf``."""
    observed_velocity_px: float | None = Field(None, gt=0.0, le=1e4)
    """Our extension: the arms' velocity in the linear motion model kept only along the joint
    directions that move the arm's projected elbow and wrist
    (:func:`~humimic.perception.trackers.kpf.velocity.observable_velocity`: the damped
    pseudo-inverse through the image Jacobian, this its damping lambda in px / rad); None:
    off, the whole velocity as the paper. The principle: a velocity direction whose motion
    over one motion-model noise extent (``motion_noise`` D, ~0.1 rad) moves the image less
    than a pixel is unobservable, lambda = 1 px / (0.25 x ~0.4 rad) ~ 10 px / rad (the wide
    eye at 2 m: singular values ~40, 8-30 and 0.5-6 px / rad). Measured (Table 1's ``kpf``,
    (1000, 3), seeds 0-4, mean wrist error, main -> 10 px / rad): angular 182 -> 143 mm
    (along the ray 179 -> 141) but side 82 -> 117 (along 73 -> 115) and the 18 s three
    gestures (schmidt_side, seeds 1-4) 77 -> 138; the error across the ray and the flip-free
    error fall everywhere (side 23 -> 12 and 49 -> 36 mm), the depth error grows. 3 px / rad:
    side 84; no arm velocity at all: side 97. With ``particle_velocity`` (each particle's
    velocity restricted): Table 1 side (seeds 0-9) 84 ± 49 -> 85 ± 24, angular (0-4) 182 ± 24
    -> 123 ± 9 (better on every seed), but the 18 s gestures 77 -> 170 (depth 68 -> 167). Off:
    the longer holds drift in depth."""
    observed_walk_px: float | None = Field(None, gt=0.0, le=1e4)
    """Our extension: the arms' propagation noise (the random group's and the motion group's)
    shaped per frame by the last best mode's image Jacobian
    (:func:`~humimic.perception.trackers.kpf.velocity.noise_shaping`): along each of the arm's
    joint-space singular directions the noise is scaled by ``floor + (1 - floor) s^2 / (s^2 +
    lambda^2)`` (this lambda, px / rad; ``observed_walk_floor`` the floor), full where the
    direction moves the elbow's and wrist's images, shrunk to the floor where it does not
    (depth-only directions, the twist of a straight arm); None: off, as the paper. Measured
    (Table 1's ``kpf``, (1000, 3), mean wrist error, main -> 10 px / rad floor 0.25): side
    seeds 0-9 84 ± 49 -> 66 ± 3 mm (along the ray ~73 -> 38, across it ~23-33 -> 44; better
    on 5 of 10 seeds, the bad seeds 152 / 188 -> 69 / 59), but angular seeds 0-4 182 ± 24 ->
    204 ± 5 (worse on 4 of 5) and the 18 s three gestures (schmidt_side, seeds 1-4) 77 ± 18 ->
    78 ± 2. Floor 0.5: side 65 ± 7, angular 238 ± 25; 3 px / rad floor 0.25: side (0-4) 78 ± 11,
    angular 240 ± 28.
    Off: it trades the image fit for depth and hurts angular pointing, whose true motion
    has components along the weak directions."""
    observed_walk_floor: float = Field(0.25, ge=0.0, le=1.0)
    """The noise factor along the directions that move no pixel, with ``observed_walk_px``."""
    observed_walk_groups: Literal["both", "random", "motion"] = "both"
    """Which propagation groups' noise ``observed_walk_px`` shapes: ``both``, or only the
    ``random`` or the ``motion`` group's (the other's noise left whole). Measured with
    ``observed_velocity_px`` 10 and ``particle_velocity`` (Table 1's ``kpf``, (1000, 3)):
    ``both``: schmidt_side (seeds 1-4) 77 ± 1 mm (main 77 ± 18), Table 1 side (0-4) 77 ± 2,
    angular (0-4) 197 ± 5 (main 182 ± 24); ``random``: angular 215 (seeds 0-2); ``motion``:
    angular 118 ± 10 but schmidt_side 115 ± 38. The random group's shaping is what keeps the
    long runs' depth and what costs angular pointing. ``both`` as before."""
    particle_velocity: bool = False
    """Our extension: each particle's motion-model velocity its own (from its ancestor's
    position last frame to where mean shift took it), carried through the resampling, instead
    of the one velocity from the last two best modes (the paper; the two coincide when the
    posterior sits on one particle). Measured (``kpf`` of Table 1 / schmidt_side, (1000, 3)):
    Table 1 side, seeds 0-4, 82 ± 44 -> 55 ± 18 mm (seeds 0-9: 84 ± 49 -> 69 ± 39, worse on
    3 of 10), but angular (0-4) 182 -> 198 and the 18 s three gestures (schmidt_side, seeds
    1-4) 77 -> 106, worse on every seed. Off."""
    particle_velocity_innovation: bool = False
    """Our extension, with ``particle_velocity``: each particle's velocity the motion model's
    velocity it was propagated with plus its mean-shift correction
    (:func:`~humimic.perception.trackers.kpf.velocity.particle_velocities`, an alpha-beta
    update without the propagation noise); False: its whole displacement, noise included.
    Measured (Table 1's ``kpf``, (1000, 3), with ``observed_velocity_px`` 10, mean wrist
    error): angular seeds 0-4 182 ± 24 (main) / 123 ± 9 (noise included) -> 116 ± 7 mm
    (seeds 5-9: main 199 -> 123, better on every seed; another person, darker skin, red
    shirt, seeds 0-2: 159 -> 137, better on 2 of 3), but
    the 18 s three gestures (schmidt_side) seeds 1-4 77 ± 18 (main) / 170 ± 60 -> 121 ± 25.
    Off."""
    particle_velocity_decay: float = Field(1.0, ge=0.0, le=1.0)
    """Our extension, with ``particle_velocity``: the factor on each particle's velocity per
    frame (1: kept whole). Measured (as above, ``observed_velocity_px`` 10): 0.5: angular
    131 ± 9, side (seeds 0-4) 90 ± 23 (main 82 ± 44), schmidt_side (1-4) 123 ± 33 (main
    77 ± 18, 1.0: 170 ± 60); 0.8: angular 134 ± 12, schmidt_side 180 ± 58. Off (1.0)."""
    keep_range_share: float = Field(0.0, ge=0.0, le=1.0)
    """Our extension: the share of the propagated particles (of ``keep_range_groups``) per arm and
    frame whose wrist, after the propagation, is put back at a reference camera distance
    (``keep_range_target``) on its new camera ray
    (:func:`~humimic.perception.trackers.kpf.depth.keep_wrist_range`): the propagation re-takes
    the image across the ray without re-drawing the depth, which the likelihood hardly judges
    (flat within ~0.5 nats over 130 mm along the ray). Part of the dynamics (the reweighting's
    prior); 0: off, as the paper. Why (per frame, Table 1's ``kpf``, (1000, 3), main): side
    pointing's bad seeds (1, 6: 152, 188 mm) lose the depth while the arm is lowered, the motion
    model's velocity carrying the wrist ~100 mm per frame towards the camera into the arm's
    kinematic flip (-450 mm along the ray, kept through the rest); the 18 s gestures
    (schmidt_side) jump in one frame of the rise (a random re-take, e.g. -30 -> -110 mm).
    Measured (mean wrist error, mm, main -> option; side seeds 0-9, angular 0-4, schmidt_side
    1-4): share 1 with the defaults below (``both`` groups, the ``ancestor``'s distance,
    clipped): side 84 ± 49 -> 41 ± 12 (better on 8 of 10; along the ray 27, |along| by phase
    rest / rise / hold / lower 83 / 89 / 33 / 89 -> 27 / 30 / 21 / 33), schmidt_side 77 ± 18 ->
    68 ± 26 (better on 3 of 4), another person (skin [0.45, 0.30, 0.22], shirt [0.25, 0.55,
    0.30], seeds 0-2) side 77 -> 49 and angular 193 -> 213; angular 182 ± 24 -> 223 ± 12 (worse
    on all 5: the depth no longer follows an arm pointing towards the camera, |along| in the
    hold 280 -> 396). Without the clip: side (seeds 1, 2, 3, 6) 32 but schmidt_side (1, 2) 117
    (main 91). Only the random group, the motion model's distance: side (0-6) 126 (main 95: the
    velocity alone carries the lowering arm into the flip); only the random group, the
    ancestor's, clipped: side 73 ± 21, angular 205 ± 14, schmidt_side 86 ± 28; only the motion
    group, the ancestor's: side (0-7) 70 (main 88), angular 201, schmidt_side 90 (main 77);
    both groups, the motion model's distance, clipped: angular (0, 1) 264, schmidt_side (1, 2)
    204. With the angular options (``particle_velocity``, ``particle_velocity_innovation``,
    ``observed_velocity_px`` 10; both, ancestor, clipped): side 56 ± 13 (better on 6 of 10),
    angular 187 ± 6 (better on 2 of 5), schmidt_side 117 ± 64 (seed 3: 62 -> 213); share 0.7
    with them: angular (0-2) 176 (main 195), schmidt_side (1, 2) 139 (main 91). Off: no setting
    beats main on all three (the frozen depth costs angular pointing)."""
    keep_range_groups: Literal["random", "motion", "both"] = "both"
    """Whose particles ``keep_range_share`` applies to: the ``random`` group's, the ``motion``
    group's, or ``both`` (the best measured, above)."""
    keep_range_target: Literal["motion", "ancestor"] = "ancestor"
    """The camera distance ``keep_range_share`` restores: ``motion``, the ancestor's moved by
    the motion model's velocity; ``ancestor`` (the best measured), the ancestor's own (no
    range rate carried)."""
    keep_range_clip: bool = True
    """With ``keep_range_share``: a wrist whose reference distance is out of the arm's reach
    (a nearly straight arm: ~40 % of a random walk's particles) moved to the nearest reachable
    distance on its ray (:func:`~humimic.perception.trackers.kpf.depth.reachable_range_change`);
    False: left where the propagation put it (the depth re-drawn after all). Only the outer
    reach is clipped: a wrist asked nearer the shoulder than the arm can fold stays where the
    propagation put it."""
    keep_range_gate_deg: tuple[float, float] | None = None
    """Our extension, with ``keep_range_share``: [lo, hi] (deg); the share of kept ranges scaled per
    arm by a smooth step of the arm's (shoulder -> wrist) angle out of the image plane
    (:mod:`~humimic.perception.trackers.kpf.depth_gate`): whole below lo, none above hi. An arm near
    the image plane projects to ``cos`` of that angle times its length, second order in its depth,
    an arm pointing towards the camera to first order: hold the depth the likelihood cannot judge,
    free the one it can. None: no gate. Measured (Table 1's ``kpf``, (1000, 3), mean wrist error,
    mm, main -> share 1 with the gate [15, 35] on each propagated particle): side seeds 0-9 85 ± 41
    -> 66 ± 18 (better on 8 of 10; along the ray 74 -> 51, across it 28 -> 33), another person (skin
    [0.45, 0.30, 0.22], shirt [0.25, 0.55, 0.30]) side seeds 0-1 105 -> 52, but angular seeds 0-4
    193 ± 28 -> 238 ± 12 (worse on all 5; the other person seed 0 172 -> 244) and the 18 s gestures
    (schmidt_side) seeds 1-4 85 ± 30 -> 147 ± 63 (seed 1 67 -> 234; ungated share 1 on the same
    main: 53 ± 3, angular 224 ± 13). Why: the error is a kinematic flip, and a flip pair lies on
    both sides of the gate (module docstring): the angular arm's flip (~13 deg away from the camera)
    is held, the side arm's (~32 deg towards it) is free, so the gate keeps the one and releases
    into the other. With ``flip_share`` 0.1 as well: angular seeds 0-1 205 / 205 (main 192 / 226),
    side seeds 1, 6 136 / 82 (main 89 / 190). Off: worse than the ungated option on the long runs
    and than main on angular pointing."""
    min_random: float = Field(0.2, ge=0.0, le=1.0)
    """Smallest share of randomly propagated particles."""
    tol: float = Field(0.01, ge=0.0)
    """Stop mean shift when the best particle moves less than this (scaled by D)."""
    reweight: Literal["kernel", "likelihood"] = "kernel"
    """After each shift: ``kernel`` (likelihood x prior KDE / proposal KDE, Chang & Ansari) or
    ``likelihood`` alone."""
    partitioned: bool = False
    """Our extension: the torso and each arm are shifted, weighted and resampled with their
    own limbs' likelihood terms (partitioned sampling), instead of the whole pose's."""
    torso_prior_m: float | None = Field(None, gt=0.0, le=10.0)
    """Our extension: a Gaussian prior (this standard deviation, m) keeping the torso near its
    start (a person standing in front of the robot); None: off, as the paper."""
    torso_prior_deg: float = Field(5.0, gt=0.0, le=180.0)
    """The prior's standard deviation of the torso's rotations (deg), with ``torso_prior_m``."""
    twist_range_deg: tuple[float, float] | None = None
    """Our extension: a soft range of motion of each upper arm's twist about its own axis
    (:func:`~humimic.bodymodel.rom.humeral_twist`; [external, internal] limits, deg, + internal;
    a person's: :data:`~humimic.bodymodel.rom.TWIST_RANGE_DEG` = [-90, 70]), a log-prior flat
    inside and falling off with ``twist_sd_deg`` outside, on the particles' weights; None: off,
    as the paper (its joint limits are a box on the Euler angles, which cannot bound the twist
    of a raised arm). Two of the three kinematic flips of Table 1's angular arm turn the forearm
    backwards (128 and 102 deg external), and the estimates reached 123 deg external (angular)
    and 145 internal (side). Measured at [-90, 70], Table 1's ``kpf``, mean wrist error (mm,
    flip-free in brackets): (1000, 3) seeds 0-9 angular 191 (68) -> 180 (55), side 84 (53) ->
    61 (47); another person (darker skin, green shirt, 1.8 m), seeds 5-7, angular 218 (65) ->
    179 (44), side 92 (47) -> 76 (42); but (150, 2) seeds 0-4 angular 218 (76) -> 198 (54), side
    91 (62) -> 126 (63), and the same frames re-tracked with another random stream at (1000, 3)
    side 58 -> 84. The arm is placed better (flip-free), which flip wins is unchanged: off in
    the scenarios."""
    twist_sd_deg: float = Field(10.0, gt=0.0, le=180.0)
    """The soft range's fall-off beyond ``twist_range_deg`` (deg, a half-Gaussian's sd)."""
    rescue_passes: int = Field(0, ge=0, le=5)
    """Our extension: when the best particle's log-likelihood falls more than ``rescue_drop``
    below the last frame's (the search lost a fast-moving arm), up to this many more
    resample / random-walk / mean-shift passes in the same frame (kept if better); 0: off,
    as the paper."""
    rescue_drop: float = Field(2.0, gt=0.0, le=100.0)
    rescue_depth_share: float = Field(0.0, ge=0.0, le=1.0)
    """The share of depth moves (``depth_share``) in the rescue passes."""
    depth_share: float = Field(0.0, ge=0.0, le=1.0)
    """Our extension: the share of particles whose wrist is moved along its camera ray per arm
    and frame (:func:`~humimic.perception.trackers.kpf.depth.wrist_depth_move`); 0: off, as
    the paper."""
    flip_share: float = Field(0.0, ge=0.0, le=1.0)
    """Our extension: the share of particles per arm and frame replaced by one of their
    kinematic flips (:mod:`~humimic.perception.trackers.kpf.flips`: the arm poses with the same
    elbow and wrist images, a jump process in the dynamics); 0: off, as the paper."""
    hand_share: float = Field(0.0, ge=0.0, le=1.0)
    """Our extension: the share of particles per arm and frame whose arm is turned about the
    shoulder towards the nearest skin blob (:mod:`~humimic.perception.trackers.kpf.hands`, a
    proposal from the skin segmentation); 0: off, as the paper. Measured (Table-1 frames,
    seeds 0-9, 0.2): no image lag on the fast rise and (150, 2) side 126 -> 74 mm, but
    (1000, 3) side 58 -> 67 (more depth drift) and +2 ms CPU per frame at (150, 2): off."""
    hand_radius_px: float = Field(20.0, gt=0.0, le=1000.0)
    """How far (px) from a particle's hand a skin blob may be to draw it."""
    hand_min_area_px: float = Field(4.0, ge=1.0, le=1e5)
    """The smallest skin blob (px^2) taken for a hand."""
    depth_extent_m: float = Field(0.25, gt=0.0, le=1.0)
    """Half-width (m) of the uniform range change of those depth moves."""
    refine_polls: int = Field(0, ge=0, le=50)
    """Our extension (``filter: kpf`` only): after mean shift, this many polls of a deterministic
    pattern search per arm (:mod:`~humimic.perception.trackers.kpf.refine`) climb the likelihood
    (the sigmas' floors) and priors from the dominant mode along each arm DOF (and with
    ``refine_depth_m`` the wrist's camera ray); the result is the estimate. 0: off, as the
    paper. Why: in Table 1's holds (``kpf``, (1000, 3), seeds 0-4) the along-ray wrist error is
    a bias and a slow drift, not jitter (side: rms 42 mm, of it |mean| 24 and a linear drift rms
    28, frame-to-frame jitter 7; angular: bias 280, jitter 12: a temporal smoothing could remove
    ~10 mm at most), and the estimate scores below the truth (margin +1.6 / +1.2 nats; above the
    truth in 6-8 % of frames): a search that stops short. Measured (mean wrist error, mm, main
    -> 6 polls, step 0.1 D, no depth direction, fed back): Table 1 side seeds 0-9 84 ± 49 -> 63
    ± 13 (the bad seeds 152 / 188 -> 82 / 61, but worse on 5 of 10; across the ray 28 -> 16,
    flip-free 53 -> 45), angular seeds 0-4 182 ± 24 -> 187 ± 12 (across 26 -> 18, flip-free 67
    -> 47), seeds 0-9 191 ± 23 -> 197 ± 18; another person (skin [0.45, 0.30, 0.22], red shirt,
    seeds 5-7) side 72 -> 64 (worse on 1 of 3), angular 172 -> 203; the 18 s gestures
    (schmidt_side, seeds 1-4) 77 ± 17 -> 91 ± 28 (worse on 3 of 4); ~9 % fewer frames per CPU
    second. The search gap closes (the estimate scores above the truth in ~50 % of frames,
    margin +0.7 / +0.1 nats) but the depth does not follow: what is left is the likelihood's
    depth ambiguity, which no local search resolves. With the 20 mm depth direction: side (0-4)
    100 ± 20, angular 162 ± 27; 12 polls: side 73 ± 32; step 0.05 D: side 99 ± 50; not fed back:
    side 90 ± 28. Like for like (``refine_feedback`` off: the same tracking, only the reported
    estimate refined): side (0-4) 82 ± 44 -> 82 ± 45 (across 23 -> 21, along 73 -> 75), angular
    182 ± 24 -> 183 ± 27 (across 26 -> 24, along 179 -> 180); with the depth direction side 85 ±
    43 (along 79). Off: no setting helps everywhere."""
    refine_step: float = Field(0.1, gt=0.0, le=2.0)
    """The pattern search's first step along each arm DOF, as a fraction of D (halved after
    each poll that finds nothing better)."""
    refine_depth_m: float = Field(0.0, ge=0.0, le=0.5)
    """Its first step (m) along the arm's depth direction (the joint-space direction that
    moves the wrist along its camera ray, keeping its image); 0: no such direction."""
    refine_feedback: bool = True
    """The refined mode is the tracker's too: it replaces the lightest particle (with the
    heaviest's weight) and drives the motion model's velocity and the colour adaptation;
    False: only reported (the tracking is the unrefined tracker's, same random stream: a
    like-for-like measure of what the refinement does to the estimate)."""
    kde_stride: int = Field(1, ge=1, le=100)
    """The reweighting's KDEs from every k-th particle (1: all, exact; more: faster)."""
    cues: KpfCues = Field(default_factory=KpfCues)
    skin_ring: float | None = Field(None, gt=1.0, le=4.0)
    """Our extension: the hands' skin surround (:mod:`~humimic.perception.trackers.kpf.
    skin_ring`), the skin fraction on a ring at this multiple of the model hand's image
    ellipse as a cost (sigma: ``sigma.skin``) added to the hand's term, so a model hand too
    small for its skin blob (too far: a kinematic mirror) scores worse; None: off, as the
    paper (skin inside the ellipse only). Measured (Table 1's ``kpf``, (1000, 3), mean wrist
    error, mm, main -> 1.5): angular seeds 0-4 193 ± 28 -> 190 ± 23 (alone it cannot move the
    estimate to a mirror 250-460 mm away); with ``flip_share`` 0.1 (the jumps that reach the
    mirrors) angular 138 ± 13 (147, 139, 152, 119, 134; ``flip_share`` alone 161 ± 45), but
    side seeds 0-4 76 ± 24 -> 122 ± 74 and the 18 s gestures (schmidt_side, seeds 1-4)
    85 ± 30 -> 131 ± 26; angular seeds 5-9 211 ± 30 -> 157 ± 53, another person (darker
    skin, green shirt, seeds 0-2) 178 -> 185. Off: the flips it needs cost side pointing."""
    branch_threshold: float | None = Field(None, gt=0.0, le=100.0)
    """Our extension: a delayed decision between each arm's kinematic flip branches
    (:mod:`~humimic.perception.trackers.kpf.branches`): per frame the log-likelihood ratio of
    the estimate's flips against it, summed by a CUSUM test; past this many nats the arm (its
    particles and estimates) moves to that flip. None: off, as the paper. Measured (Table 1's
    ``kpf``, (1000, 3), mean wrist error mm, main -> 0.5 with ``branch_skin_ring`` 1.5 and
    ``branch_refine_polls`` 3): angular seeds 0-4 193 ± 28 -> 101 ± 18 (192 / 226 / 213 / 155 /
    181 -> 119 / 94 / 122 / 83 / 88), but side seeds 0-3 108 / 89 / 67 / 45 -> 163 / 75 / 65 /
    140 and the 18 s gestures (schmidt_side) seeds 1-3 67 / 122 / 95 -> 178 / 104 / 140 (false
    switches: the side arm's wrist flip scores as the truth, -0.01 nats); another person
    (skin [0.45, 0.30, 0.22], green shirt, seed 0)
    angular 258 -> 94, side 60 -> 63; frames per CPU second ~9.7 -> ~5.8 (under load).
    Threshold 0.8: angular seed 0 250, side 0 85, schmidt_side 1 191; 1.0 with forgetting 0.95:
    angular 0 250. Off: not better on all three."""
    branch_forget: float = Field(0.9, ge=0.0, le=1.0)
    """The CUSUM's forgetting factor per frame (1: none)."""
    branch_refine_polls: int = Field(0, ge=0, le=50)
    """Pattern-search polls (step ``refine_step``) refining the estimate's arm and each
    flip before their ratio (0: the flips of the estimate as they are)."""
    branch_skin_ring: float | None = Field(None, gt=1.0, le=4.0)
    """The branch decision's likelihood with this ``skin_ring`` (the filter's own without it);
    None: the filter's likelihood."""
    colour_gradients: bool = False
    """Our extension: the edge and ridge cues on the strongest colour channel's derivatives
    at each pixel instead of grey levels' (clothes as bright as the background keep their
    edges); False: grey levels, as the paper."""
    edge_points: int = Field(20, ge=2, le=200, multiple_of=2)
    """M_E, even."""
    ridge_points: int = Field(30, ge=1, le=200)
    bands_arm: int = Field(3, ge=1, le=10)
    bands_torso: int = Field(4, ge=1, le=10)
    sigma: KpfSigma = Field(default_factory=KpfSigma)
    sigma_from_spread: bool = True
    adapt: float = Field(0.2, ge=0.0, le=1.0)
    """Eq. 7's adaptation factor of the mean colours."""
    lost_cost: float = Field(0.75, gt=0.0, le=2.0)
    """Lost when the best mode's mean cue cost exceeds this."""
    latency: float = Field(0.0, ge=0.0, le=5.0)
    """Declared processing delay of a pose estimate (s)."""

    @model_validator(mode="after")
    def _check(self) -> KpfConfig:
        if self.twist_range_deg is not None and not (
                -180.0 <= self.twist_range_deg[0] < self.twist_range_deg[1] <= 180.0):
            raise ValueError("twist_range_deg must be [low, high] with -180 <= low < high <= "
                             f"180 (deg), got {list(self.twist_range_deg)}")
        if self.keep_range_gate_deg is not None and not (
                0.0 <= self.keep_range_gate_deg[0] < self.keep_range_gate_deg[1] <= 90.0):
            raise ValueError("keep_range_gate_deg must be [lo, hi] with 0 <= lo < hi <= 90 "
                             f"(deg), got {list(self.keep_range_gate_deg)}")
        return self

    def D(self, frame_rate: float | None = None) -> list[float]:
        """The 14 propagation extents (m, rad) in :data:`humimic.bodymodel.DOF_NAMES` order,
        for frames at ``frame_rate`` (Hz; None: ``D_rate``)."""
        import math

        k = 1.0 if frame_rate is None else math.sqrt(self.D_rate / frame_rate)
        t, r = k * self.D_torso_m, k * math.radians(self.D_torso_deg)
        arm = [k * math.radians(a) for a in self.D_arm_deg]
        return [t, t, t, r, r, r] + arm + arm
