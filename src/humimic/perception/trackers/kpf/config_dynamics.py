"""The motion model's and propagation's options of the kpf tracker's config (``kind: kpf``;
:class:`~humimic.perception.trackers.kpf.config.KpfConfig` derives from it, so the keys are
``trackers.<name>.<key>`` as before): the extents D (Schmidt sec. 5.2 and 6), the linear motion
model and our extensions to the propagation.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from humimic.scenario.base import Section

#: One arm DOF's propagation extent (deg).
ArmExtent = Annotated[float, Field(gt=0.0, le=180.0)]


class KpfDynamics(Section):
    """The kpf tracker's dynamics: propagation extents, motion model, our extensions to them."""

    D_arm_deg: list[ArmExtent] = Field(default_factory=lambda: [22.0, 20.0, 35.0, 25.0],
                                   min_length=4, max_length=4)
    """Propagation extent per arm DOF: SFE, SAA, HR, EB (deg)."""
    D_torso_deg: float = Field(2.0, gt=0.0, le=45.0)
    D_torso_m: float = Field(0.03, gt=0.0, le=0.5)
    D_rate: float = Field(7.5, gt=0.0, le=240.0)
    """The frame rate (Hz) the extents D are for (the paper's 7.5 Hz); at another camera rate
    they scale by ``sqrt(D_rate / rate)``, a random walk's spread over the same time."""
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
    keep_range_straight_deg: float | None = Field(None, ge=0.0, le=180.0)
    """Our extension, with ``keep_range_share``: no kept range for a propagated particle whose
    arm's elbow is flexed less than this (deg) (:func:`~humimic.perception.trackers.kpf.depth.
    nearly_straight`; the particle left where the propagation put it). Near the straight limit
    the re-solve can only bend the arm (the wrist moved along its ray towards the shoulder; the
    other way is out of reach), so every frame it bent a straight hanging arm a little more,
    and the motion model's velocity carried the bend on (docs/schmidt_kpf_notes.md, "Round of
    29 Nov (4)"). Skipped both ways: dropping only the bending re-solves made the rule
    one-sided the other way, a ratchet that straightened a bent arm once it came under the
    threshold. Measured (Table 1's ``kpf``, (1000, 3), seeds 0-7, mean wrist error, mm, None ->
    20): the idle straight left arm's wrist 108 -> 18, right wrist side 38.4 -> 36.9, angular
    198 -> 204 (worse on 6 of 8); a static person's arms 108 -> 16; ``schmidt_side`` (seeds
    1-4) 60 -> 55. 10 deg does not hold the left arm (up to 204 mm): the threshold has to cover
    the walk's reach from the limit. 20 in Table 1's ``kpf`` and ``schmidt_side``. None:
    every drawn particle's range kept."""
    min_random: float = Field(0.2, ge=0.0, le=1.0)
    """Smallest share of randomly propagated particles."""

    @model_validator(mode="after")
    def _check_dynamics(self) -> KpfDynamics:
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
