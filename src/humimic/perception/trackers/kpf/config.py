"""Scenario config of Schmidt, Fritsch & Kwolek's kernel-particle-filter tracker (``kind: kpf``).

Defaults are the paper's experiment (sec. 6): cues torso {edge, colour}, upper arm {edge,
ridge, colour}, forearm {edge, ridge}, hand and head {skin}; M_E = 20, M_R = 30, B_arm = 3,
B_torso = 4; D_arm = [22, 20, 35, 25] deg (shoulder SFE, SAA, HR, elbow; the text is garbled
around the degree signs, we read the four numbers as degrees), D_torso 2 deg and 3 cm (the
paper: "1-3 deg" and "1-5 cm"); h0 = D, h = 0.8^i h0, the mode window 0.25 D; the motion model's
noise 0.25 D.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from humimic.perception.trackers.kpf.config_dynamics import KpfDynamics
from humimic.scenario import base
from humimic.scenario.base import Section


class KpfCues(Section):
    """Cues per limb type (Schmidt sec. 6). ``colour`` on the forearm is our extension (the
    paper's forearm has edge and ridge only): the mean-colour cue (eqs. 5-7) of a forearm in a
    sleeve, which tells the limb from a background stripe of similar contrast beside it; the
    sleeve's ridge alone depends on the shirt's contrast to the wall (``i14-shirt``,
    docs/schmidt_kpf_notes.md)."""

    torso: list[Literal["edge", "ridge", "colour"]] = Field(
        default_factory=lambda: ["edge", "colour"])
    upper_arm: list[Literal["edge", "ridge", "colour"]] = Field(
        default_factory=lambda: ["edge", "ridge", "colour"])
    forearm: list[Literal["edge", "ridge", "colour"]] = Field(
        default_factory=lambda: ["edge", "ridge"])
    hand: list[Literal["skin"]] = Field(default_factory=lambda: ["skin"])
    head: list[Literal["skin"]] = Field(default_factory=lambda: ["skin"])


class KpfSigma(Section):
    """Eq. 9's standard deviations of each cue's cost: the floor under the spread of the
    responses over the particles (``sigma_from_spread``), or the value itself."""

    edge: float = Field(0.15, gt=0.0, le=10.0)
    ridge: float = Field(0.3, gt=0.0, le=10.0)
    colour: float = Field(0.1, gt=0.0, le=10.0)
    skin: float = Field(0.3, gt=0.0, le=10.0)


NEEDS: dict[str, tuple[str, ...]] = {
    "split_resample": ("split_arms",), "twist_sd_deg": ("twist_range_deg",),
    "torso_prior_deg": ("torso_prior_m",),
    "rescue_drop": ("rescue_passes",), "rescue_depth_share": ("rescue_passes",),
    "depth_extent_m": ("depth_share", "rescue_depth_share"),
    "hand_radius_px": ("hand_share",), "hand_min_area_px": ("hand_share",),
    "refine_step": ("refine_polls", "branch_refine_polls"),
    "refine_depth_m": ("refine_polls",), "refine_feedback": ("refine_polls",),
    **{k: ("branch_threshold",) for k in ("branch_forget", "branch_refine_polls",
                                          "branch_skin_ring", "branch_min_separation_mm",
                                          "branch_max_step_mm", "branch_max_ratio",
                                          "branch_clamp_flips")},
    **{k: ("observed_walk_px",) for k in ("observed_walk_floor", "observed_walk_groups")},
    **{k: ("particle_velocity",) for k in ("particle_velocity_innovation",
                                           "particle_velocity_decay")},
    **{f"keep_range_{k}": ("keep_range_share",) for k in ("groups", "target", "clip",
                                                          "gate_deg", "straight_deg")},
}
"""Our options that act only with another on: option -> the options that switch it on."""


def idle_options(cfg: KpfDynamics) -> list[tuple[str, tuple[str, ...]]]:
    """:func:`~humimic.scenario.base.idle_options` of ``cfg`` with :data:`NEEDS`."""
    return base.idle_options(cfg, NEEDS)


FOVEA_PARTS = ("r_upper_arm", "r_forearm", "r_hand", "l_upper_arm", "l_forearm", "l_hand")


class KpfFovea(Section):
    """Our extension (:mod:`~humimic.perception.trackers.kpf.fovea`): the arm limbs' cue terms
    also in the same eye's narrow (foveal) camera, whose gaze the scenario's ``mimic.gaze``
    (``tracker:`` this tracker, ``target: right_elbow``) keeps on the tracker's estimate
    (``scenarios/schmidt_table1_fovgaze.yaml``). Measured (Table 1's ``kpf`` at (1000, 3),
    seeds 0-4, mean wrist error, mm, side / angular): alone 48.7 / 192 (Table 1's 41.7 /
    197); with ``branch_threshold`` 1.0, ``branch_refine_polls`` 3 and
    ``branch_min_separation_mm`` 200 50.8 / 61.6, seeds 5-9 51.7 / 68.2 (Table 1's 38.9 / 199;
    the decision without the fovea, ungated: 70.8 / 195); with ``skin_in_view: search`` (the
    scenario's) 35.6 / 60.6 (seeds 5-9 41.2 / 88.0: angular worse); frames per CPU second
    x0.52 at (150, 2), x0.72 at (1000, 3).
    Off: (150, 2) falls below its speed goal."""

    camera: Literal["L_foveal", "R_foveal"] | None = None
    """The foveal camera (rendered: ``cameras.which: both``; ``R_foveal``: ``cameras.eyes:
    stereo``); None: ``L_foveal`` unless ``cameras`` is given."""
    cameras: list[Literal["L_foveal", "R_foveal"]] | None = Field(None, min_length=1,
                                                                   max_length=2)
    """Several foveal cameras, each a conditionally independent view (e.g. ``[L_foveal,
    R_foveal]``: the two eyes' narrow pair, stereo; ``scenarios/schmidt_table1_stereo.yaml``);
    None: ``[camera]``. Not with ``camera``. Measured (29 Nov, ``i14-stereo``, (1000, 3), mean
    wrist error, angular / side, mm, seeds 0-9): ``L_foveal`` 73.2 / 40.5, ``R_foveal`` 74.5 /
    43.3, both 67.5 / 57.5; both with ``weight`` 1.5 and ``keep_range_straight_deg`` 20
    59.4 / 56.1 (seeds 10-19: 60.3 / 50.5, ``L_foveal`` 77.6 / 34.5)."""
    parts: list[Literal[FOVEA_PARTS]] = Field(
        default_factory=lambda: ["r_upper_arm", "r_forearm", "r_hand"], min_length=1)
    """The limbs scored in it."""
    weight: float = Field(1.0, gt=0.0, le=10.0)
    """Its factors' exponent (1: the two views' likelihoods multiplied)."""
    use: Literal["all", "decision", "moving"] = "all"
    """Which evaluations see it: ``all`` (the mean shift, the reweighting, the refinements
    and the flip-branch decision); ``decision``: only the flip-branch decision's
    (``branch_threshold``; :func:`~humimic.perception.trackers.kpf.fovea.decision_view`), the
    rest the wide view alone; ``moving``: all while the estimate's arm moves (``moving_mm``),
    else only the decision's. Measured (``schmidt_table1_fovgaze``, seeds 0-9, side /
    angular mm; 29 Nov, ``i14-fang``): all 51.2 / 64.9, decision 39.6 / 100.0 (the wide search
    loses the arm in the lowering, then its flips are out of the decision's reach), moving
    36.5 / 79.5 (a wide-only hold drifts and the decision switches it wrongly); Table 1's
    wide-only kpf 40.3 / 198."""
    moving_mm: float = Field(20.0, gt=0.0, le=1000.0)
    """``use: moving``: the wrist step (mm) between the last two estimates above which the
    arm counts as moving (10: side 43.3, angular 76.0 on seeds 0-9, one side run lost)."""
    decision_weight: float | None = Field(None, gt=0.0, le=10.0)
    """The exponent in the flip-branch decision's evaluations; None: ``weight``. (``weight``
    0.5 with ``decision_weight`` 1: angular 148 and 144 on seeds 0-1, worse than either.)"""
    in_view_margin_px: float | None = Field(None, ge=0.0, le=100.0)
    """Score in it only the parts wholly inside its image, this far from the border, at the
    last estimate (:func:`~humimic.perception.trackers.kpf.fovea.parts_in_view`); None: all
    ``parts`` every frame."""
    skin_in_view: Literal["search", "all"] | None = None
    """The hands' skin cue in it with its sample points off the narrow image read in the wide
    view (:func:`~humimic.perception.trackers.kpf.fovea.in_view_skin`): ``search`` in the
    filter's evaluations, not in the fixed-sigma ones of the branch decision and the
    refinement; ``all`` in every evaluation; None: eq. 8 over all points, off-image ones
    reading no skin (which pulled the resting hand into the narrow image)."""

    @model_validator(mode="after")
    def _check_cameras(self) -> KpfFovea:
        if self.cameras is not None:
            if self.camera is not None:
                raise ValueError("set fovea.camera or fovea.cameras, not both")
            if len(set(self.cameras)) != len(self.cameras):
                raise ValueError(f"fovea.cameras {self.cameras} names a camera twice")
        return self

    @property
    def names(self) -> tuple[str, ...]:
        """The foveal cameras: ``cameras``, or ``(camera,)`` (``L_foveal`` if None)."""
        return tuple(self.cameras) if self.cameras is not None else (self.camera or "L_foveal",)


class KpfConfig(KpfDynamics):
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
    shrink: float = Field(0.8, gt=0.0, lt=1.0)
    """Bandwidth factor per iteration, h = shrink^i D."""
    window: float = Field(0.25, gt=0.0, le=2.0)
    """Dominant-mode window, as a fraction of D."""
    tol: float = Field(0.01, ge=0.0)
    """Stop mean shift when the best particle moves less than this (scaled by D)."""
    reweight: Literal["kernel", "likelihood"] = "kernel"
    """After each shift: ``kernel`` (likelihood x prior KDE / proposal KDE, Chang & Ansari) or
    ``likelihood`` alone."""
    partitioned: bool = False
    """Our extension: the torso and each arm are shifted, weighted and resampled with their
    own limbs' likelihood terms (partitioned sampling), instead of the whole pose's."""
    split_arms: bool = False
    """Our extension, with ``partitioned``: each arm split into a shoulder group (SFE, SAA, HR;
    weighted with the whole arm's terms) and an elbow group (EB; the forearm's and hand's),
    five groups (:mod:`~humimic.perception.trackers.kpf.split`). Measured (Table 1's ``kpf``,
    (1000, 3), mean wrist error, seeds 0-9, main -> on): side 85 ± 41 -> 67 ± 16 mm, angular
    202 ± 29 -> 193 ± 36; another person (seeds 0-4) side 85 ± 37 -> 52 ± 13, angular 190 ± 21
    -> 202 ± 46; 72 -> 80 ms CPU per frame. Off: the goals stay unmet."""
    split_resample: Literal["groups", "arm"] = "groups"
    """With ``split_arms``: resample each of the five groups from its own ancestor
    (``groups``), or an arm's shoulder and elbow from one (``arm``)."""
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
    branch_max_ratio: float | None = Field(None, gt=0.0, le=100.0)
    """The per-frame ratios clipped to +- this (nats) before the CUSUM (:func:`~humimic.
    perception.trackers.kpf.branches.clip_ratios`, Huber's robust ratio test): a switch needs
    several frames' evidence. None: as they are. Measured at 0.5 with threshold 1.0 and the
    two gates above (200 mm, 20 mm): side 40.7 ± 2.8, angular 211 ± 10 (seeds 0-9), another
    person's side seed 3 143 -> 57, the narrow eye side 69 ± 20, angular 115 ± 11. Off."""
    branch_skin_ring: float | None = Field(None, gt=1.0, le=4.0)
    """The branch decision's likelihood with this ``skin_ring`` (the filter's own without it);
    None: the filter's likelihood."""
    branch_min_separation_mm: float | None = Field(None, gt=0.0, le=2000.0)
    """A loss-aware branch decision: only flips whose wrist lies at least this far (mm) from
    the estimate's (before ``branch_refine_polls``) are scored, enter the CUSUM and may be
    switched to; a nearer flip's sum restarts at 0 (:func:`~humimic.perception.trackers.kpf.
    branches.gate_near_flips`). A near flip costs little if wrong and its evidence is the
    weakest (Table 1's side hold: the wrist flip 104 mm, the double 147 mm from the truth, tied
    with it; the angular hold's flips 250-470 mm). None: every flip. Measured (Table 1's
    ``kpf`` with the pair, (1000, 3), threshold 0.5, ring 1.5, 3 polls, mean wrist error, mm,
    seeds 0-4; the pair alone side 42, angular 197; without the gate 91 / 116): 200 mm: angular
    125 ± 26 but side 146 ± 25: with the near ties gated the double flip (400-530 mm away) wins
    during the rise, as it does, rightly, for angular pointing. Off."""
    branch_max_step_mm: float | None = Field(None, gt=0.0, le=2000.0)
    """The branch decision only for a still arm: an arm whose estimated wrist moved farther
    than this (mm) since the last estimate is not scored and its sums restart (while the arm
    moves the estimate lags the image, and a flip's refined pose can catch up: in Table 1's
    rise both gestures gave the double flip +0.3-1 nats a frame, right for angular pointing,
    wrong for side pointing). None: every frame. Measured with ``branch_min_separation_mm``
    200 (as above, seeds 0-9; the pair alone side 40.3 ± 3.5, angular 198 ± 10): 20 mm,
    threshold 0.5: side 48 ± 22 (seed 8 107), angular 170 ± 30; threshold 1.0: side 40.0 ±
    2.2, angular 209 ± 9 (the holds are decided late or not at all); with it, seeds 0-4, the
    narrow eye angular 184 -> 116 ± 11 but side 66 -> 74 ± 26, another person side 54 -> 71 ±
    40; (150, 2) ~2x the CPU per frame. Off."""
    branch_clamp_flips: bool = False
    """A flip of the estimate outside the joint limits is clamped into them (and refined with
    ``branch_refine_polls``) and scored instead of left out (29 Nov, ``i14-fdec``: at the end of
    the angular lowering the truth lies 20-45 mm from the estimate's double flip, which leaves
    the limits, so the decision had no ratio to sum while the estimate was 240-340 mm off).
    Measured (``schmidt_table1_fovgaze``, (1000, 3), seeds 0-9): angular 74 -> 62 ± 13 mm (seeds
    5, 8, 9 107 / 136 / 103 -> 64 / 64 / 84; 1 and 4 worse by 2 and 12), side 38.4 (every seed
    unchanged); set there. False: such flips are not scored, as before."""
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
    fovea: KpfFovea | None = None
    """Our extension: a second, foveal view of the arms (:class:`KpfFovea`); None: off."""

    @model_validator(mode="after")
    def _check(self) -> KpfConfig:
        if self.split_arms and not self.partitioned:
            raise ValueError("split_arms needs partitioned: true (it splits the partitioned "
                             "arms into shoulder and elbow groups)")
        base.reject_idle_options(self, NEEDS)
        if self.twist_range_deg is not None and not (
                -180.0 <= self.twist_range_deg[0] < self.twist_range_deg[1] <= 180.0):
            raise ValueError("twist_range_deg must be [low, high] with -180 <= low < high <= "
                             f"180 (deg), got {list(self.twist_range_deg)}")
        return self
