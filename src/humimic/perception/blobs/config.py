"""The scenario's ``perception`` section: Ude & Atkeson's colour-blob stereo tracker.

Example (every key optional)::

    perception:
      tracker: em_blobs
      targets: [head, right_hand, left_hand]
      color_model: auto         # learned for this scenario's person (or a file, e.g.
                                #   ../models/colors/skin.json)
      roi_side: 20              # EM samples per ROI side (the fixed window the ROI maps onto)
      em_iterations: 6
      detection: {period: 5.0, lam: 0.67, restart_phase: 2}
      pixel_std: 0.28           # blob-centre noise (px) } propagated through triangulation
      match_std: 0.04           # stereo-match noise (px) } into each measurement's R
      match_floor_px: null      # disparity floor of hard-edged outlines (px; 0.08 measured)
      latency: null             # s added to each measurement's t_ready (null: one frame)

Units: s, px, m. Target names are the avatar's visible coloured parts.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator, model_validator

from humimic.paths import MODELS_DIR
from humimic.perception.blobs.triangulation import NOISE_REF_SIGMA_PX
from humimic.scenario.base import Section
from humimic.world.names import EYE_CAMERAS

#: Targets the blob tracker can follow: the skin-coloured parts of the avatar.
TRACKABLE_TARGETS = ("head", "right_hand", "left_hand")
TrackableTarget = Literal["head", "right_hand", "left_hand"]
EyeCamera = Literal[tuple(EYE_CAMERAS.values())]
#: The shipped colour model (learnt by ``learn_colors`` for the default person); scenarios
#: learn their own unless they name a file (``perception.color_model``).
DEFAULT_COLOR_MODEL = MODELS_DIR / "colors" / "skin.json"


class DetectionConfig(Section):
    """Automatic detection and recovery (Ude eqs. 8-9)."""

    period: float = Field(5.0, ge=0.0, le=60.0)
    """Phase one (s): random hypotheses sample the colour sums before the threshold is set
    (the paper: 5 s). 0 sets the threshold from the first frame."""
    lam: float = Field(0.67, gt=0.0, lt=1.0)
    """lambda of eq. 9 (the paper: 0.67)."""
    restart_phase: Literal[1, 2] = 2
    """After a loss, restart detection from phase 1 (re-learn the threshold) or 2."""
    hypotheses: int = Field(16, ge=1, le=1000)
    """Random blob hypotheses per target per frame."""
    score: Literal["density", "posterior"] = "posterior"
    """What eq. 8 sums over a hypothesis window: the colour density p (as written) or
    p / (p + 1), the pixel's probability of having the target's colour (robust to shading)."""
    proposal: Literal["uniform", "color"] = "color"
    """uniform: the paper's; color: half the centres drawn from a coarse colour map."""
    refine_fit: bool = True
    """Our extension: the colour-drawn hypotheses' shapes, fitted on the coarse colour map,
    take one full-resolution moment step before eq. 8 scores them, and the step and the score
    see only the hypothesis' own blob of the coarse map (the 8-connected component its centre
    fell in, with the unlabelled cells around it that border no other blob). A hand narrower
    than a map cell (the hanging hand, 5-8 px in the wide 320x240 eyes) got a coarse fit half a
    cell off and too thin, whose window it filled 62 % (f 160 under eq. 9's 170, every frame).
    Ungated (the first version), the widened window took in the head or hand beside it:
    ude_hidden_target seed 1 (5 s) head 0.96 -> 0.69, hand 0.94 -> 0.39 with 31 % false
    reports. Gated, measured against off (detection rates): ude_hidden_target seed 1 head
    0.962 -> 0.951, hand 0.942 -> 0.942 (false 1.1 % both); ude_wave_tracking waving the left
    hand (4 s), seeds 23 / 4 / 1 / 31: the hanging right hand 0 -> 0.927 on each, no false
    report, the head 0.944 -> 0.927; sweeps/people.yaml: the hanging hand at 1.5 m (7 px) and
    with the left hand waving never -> 0.961 (at 2.0 m, 5 px, still never); ude_cmu_turn seed 1
    head / right / left 0.827 / 0.475 / 0.423 -> 0.850 / 0.500 / 0.451. Search CPU per
    searching frame ~1.8x (ude_hidden_target seed 1)."""
    sigma_min_px: float = Field(3.0, gt=0.0)
    sigma_max_px: float = Field(30.0, gt=0.0)
    """Limits of the hypotheses' standard deviations (px)."""
    min_fill: float = Field(0.3, ge=0.0, le=1.0)
    """A blob assigned fewer pixels than this fraction of its ellipse is losing its target."""
    lost_frames: int = Field(3, ge=1, le=100)
    """Consecutive low-fill frames before a target is declared lost."""
    backoff_s: float = Field(2.0, ge=0.0)
    backoff_every: int = Field(3, ge=1, le=60)
    """After ``backoff_s`` of fruitless searching, search only every ``backoff_every`` frames
    (a target that is absent costs less); any loss restores searching every frame."""

    @model_validator(mode="after")
    def _sizes(self) -> DetectionConfig:
        if not self.sigma_min_px < self.sigma_max_px:
            raise ValueError(f"sigma_min_px ({self.sigma_min_px}) must be below sigma_max_px "
                             f"({self.sigma_max_px})")
        return self


class StereoConfig(Section):
    """Stereo correspondence (Ude eq. 10) and triangulation."""

    template_half: int = Field(8, ge=2, le=20)
    """The ZNCC box template has (2 half + 1)^2 samples."""
    prefilter_sigma: float = Field(0.8, ge=0.0, le=3.0)
    """Gaussian blur (px) of the images before templates and strips are sampled (anti-aliasing;
    0.8 uses OpenCV's fast 3x3 kernel)."""
    fine_steps: int = Field(4, ge=1, le=16)
    """Sub-sample search: the template is correlated at 1/fine_steps of its sample spacing
    around the best sample before the parabola fit (1: parabola on the samples only)."""
    template_sigma: float = Field(1.5, gt=0.0, le=5.0)
    """The template spans +- this many of the left blob's largest standard deviations."""
    min_zncc: float = Field(0.5, ge=-1.0, le=1.0)
    """Matches scoring below this are rejected."""
    box_sigma: float = Field(1.5, gt=0.0, le=10.0)
    """The search runs along the epipolar line within the right blob's +- box_sigma box."""
    color_mask: bool = True
    """Match colour-masked images: each pixel times its probability of having the target's
    colour, so the background around a blob (at another depth, so shifted differently between
    the eyes) turns black and only the blob, its outline and shading, is matched. False: the
    paper's plain box template (background clutter can pull the match)."""
    mask_closing: int = Field(1, ge=0, le=5)
    """Our extension: the colour mask's probability image is closed (dilated, then eroded) by a
    square of this half-width (px) before it multiplies the image, so that holes the pixel
    noise punches into a blob's mask are filled alike in both eyes. A shirt of nearly the skin's
    colour ([0.76, 0.60, 0.45]) left the skin's colour table cut in the bins both share (the
    background cut, ``background_odds``), and 12-25 % of the head's and hands' pixels dropped
    out, differently in each eye; the template matched that speckle (ude_wave_tracking seed 3:
    depth error std 1.5 -> 13-17 mm, measured in docs/ude_perception_notes.md). 0: the plain
    per-pixel mask."""
    occlusion_check: bool = True
    """Our extension: a match is refused (reason ``shrinking_blob``) while its blob is being
    hidden unequally in the two eyes -- a half-occluded blob, whose outline then ends at a
    nearer edge that the match follows (:mod:`humimic.perception.blobs.occlusion`): in some
    eye the target pixels of the matched window fell by ``occlusion_min_drop`` of their median
    over the last ``occlusion_window_s`` and by ``occlusion_spread_k`` times their relative
    frame-to-frame noise there (frames found hidden stay out of that reference), and the two
    eyes' drops differ by ``occlusion_min_asymmetry``."""
    occlusion_window_s: float = Field(0.2, gt=0.0, le=2.0)
    occlusion_min_drop: float = Field(0.2, gt=0.0, le=1.0)
    occlusion_spread_k: float = Field(3.0, ge=0.0, le=20.0)
    occlusion_min_asymmetry: float = Field(0.05, ge=0.0, le=1.0)


class TargetColor(Section):
    """A colour model for one target (overrides ``color_model``)."""

    target: TrackableTarget
    file: Literal["auto"] | Path
    """A colour-model file, or ``auto`` (learned for the scenario)."""


class PerceptionConfig(Section):
    """Colour-blob tracking in both eyes, stereo 3-D measurements in the robot base frame."""

    tracker: Literal["em_blobs"] = "em_blobs"
    """em_blobs: EM colour blobs (Ude eqs. 1-7) + detection (eqs. 8-9) + stereo (eq. 10)."""
    targets: list[TrackableTarget] = Field(
        default_factory=lambda: list(TRACKABLE_TARGETS), min_length=1)
    """Targets measured and published."""
    cameras: tuple[EyeCamera, EyeCamera] | None = None
    """(left, right) eye cameras; default: the ones the scenario renders (``cameras.which``)."""
    color_model: Literal["auto"] | Path = "auto"
    """Colour model of every target: ``auto`` (learned at start-up for this scenario's skin,
    face, lights, cameras and noise from the run's own renders, cached on disk; see
    :mod:`humimic.perception.cues.auto_colors`) or a colour-model file (written by
    ``learn_colors``, e.g. ``models/colors/skin.json``)."""
    colors: list[TargetColor] = Field(default_factory=list)
    """Per-target colour models, overriding ``color_model``."""
    background_odds: float | None = Field(1.0, gt=0.0, le=1000.0)
    """Our extension: the ``auto`` model's table is cleared in the colours where the scene's other
    pixels (clothes, room) outnumber the skin's this many times in the learning renders
    (:data:`~humimic.perception.cues.auto_colors.BACKGROUND_ODDS`, kept equal by a test); None:
    only the colours the skin never showed. Measured (ude_fig1_axes seed 77, 3 s): a dark skin
    among lab_clutter's posts 2.5 -> 92 % of visible frames, a skin-like shirt 28 -> 89 %; the
    default person's table unchanged. The cost: the shade of a dark skin goes with the posts
    (8.5 % of the hanging left hand's pixels in ude_wave_tracking, skin [0.45, 0.30, 0.22] in
    lab_clutter: its raw RMSE 8.4 -> 15.8 mm, detected 88 -> 93 %). Odds 2 / 4: that hand 13.8 /
    10.4 mm, but the shirt 80 / 23 %."""
    identify_all: bool = True
    """Also track the other trackable parts that share a target's colour model (reported as
    distractors, not published), so that e.g. a hand is never taken for the head."""
    track_facing: bool = True
    """Our extension (with ``lock_names``): when the names the locks fix (the head's among them,
    in both eyes: :func:`~humimic.perception.blobs.identity.fixed_names`) break the image rules
    (at least :data:`~humimic.perception.blobs.identity.TURN_RULES` violations over both eyes)
    and the rules of a person with the back to the robot not at all, the person is judged
    turned round and the rules are mirrored (their right hand on the image's right) until
    locked names show the reverse, or the person (head and hands) is lost in both eyes;
    ``perception.facing_turns`` counts the turns judged. Measured (ude_cmu_turn seed 1):
    one turn, no false report on either hand (lock alone 6 % / 12 %, main 31 % / 12 %)."""
    identity_margin: float = Field(1.0, ge=0.0, le=10.0)
    """A target is measured only when the evidence for its identity beats the next best
    assignment by this much (rule units, see :mod:`humimic.perception.blobs.identity`); 0 also
    publishes guesses (e.g. a lone blob seen by one eye first)."""
    lock_names: bool = True
    """Our extension: a blob whose name was sure keeps it while its region of interest touches
    no other same-coloured blob's (EM cannot have swapped it), whatever the image rules (which
    assume a person facing the robot) say; while regions touch the lock is held aside and given
    back when they part if every frame's step kept the blob on its own object
    (:func:`~humimic.perception.blobs.identity.stayed_on_own_blob`), else the blobs are
    renamed when they part and locked again only if that decision is sure; a kept name they
    contradict is not published (:mod:`humimic.perception.blobs.identity`). False: the rules
    may rename any blob at an identity decision. Measured (ude_cmu_turn seed 1, a person
    turning round): the rules renamed the tracked left hand the right one, 31 % of the right
    hand's reports false; with the lock 6 % (without ``track_facing``), detection rates
    unchanged. Seeds 3 and 4, the hands touching as the turn began: without the held lock
    37 % of the right hand's reports false (predicted RMSE 438 / 469 mm), with it none."""
    roi_side: int = Field(20, ge=4, le=200)
    """EM samples per side of each blob's region of interest (cost is bounded by it)."""
    roi_k_sigma: float = Field(3.0, gt=0.0, le=10.0)
    """The ROI spans +- this many blob standard deviations (plus a 4 px margin)."""
    em_iterations: int = Field(6, ge=1, le=100)
    """Largest number of EM iterations per frame."""
    em_tol_px: float = Field(1.0, gt=0.0)
    """EM stops when no blob centre moved more than this (px)."""
    lut_bits: int = Field(6, ge=3, le=8)
    """Bits per channel of the colour look-up table."""
    detection: DetectionConfig = Field(default_factory=DetectionConfig)
    stereo: StereoConfig = Field(default_factory=StereoConfig)
    pixel_std: float = Field(0.28, gt=0.0, le=20.0)
    """Standard deviation (px, per image axis) of a measured blob centre. It depends on the
    resolution, the blobs' size and motion: calibrate it per scenario from its own renders
    (``python -m humimic.perception.calibrate SCENARIO.yaml``; measured 0.15 px for a still
    hand at 640x480 to 0.96 px through the foveal cameras). The default is the fit for the wide
    cameras at 320x240 (``ude_wave_tracking``, ``mimic_tracked_wave``: 0.27-0.28)."""
    match_std: float = Field(0.04, gt=0.0, le=20.0)
    """Standard deviation (px) of the stereo match along the epipolar line, on top of the left
    centre's error that the template carries over; calibrated with ``pixel_std`` (0.014 px for
    a still hand at 640x480 to 0.08 px for a hand moving along the depth axis; default: the
    wide 320x240 fit, 0.039-0.044)."""
    noise_ref_sigma_px: float | None = Field(NOISE_REF_SIGMA_PX, gt=0.0, le=100.0)
    """Our extension: ``pixel_std`` and ``match_std`` hold for blobs at least this wide (the mean
    of a blob's two standard deviations, px) and grow as ``noise_ref_sigma_px / sigma_blob``
    for smaller ones, down to 2.5 px (``SMALL_BLOB_FLOOR_PX``; at most twice the noise)
    (:func:`~humimic.perception.blobs.triangulation.small_blob_scale`): a blob's outline is
    sampled by fewer pixels the smaller (the farther) it is. Measured
    (mimic_tracked_wave seed 7, skin [0.45, 0.30, 0.22], 1.8 m): with fixed noises the waving
    hand's filtered NEES was in the 95 % band on 73 % of frames, the stereo error 1.5-2x the
    R it reported. None: the calibrated noises for every blob."""
    match_floor_px: float | None = Field(None, gt=0.0, le=5.0)
    """Our extension: a floor (px) added in quadrature to the (grown) ``match_std``, the
    disparity error of a blob outline cut at whole pixels, constant while the target is still
    (:func:`~humimic.perception.blobs.triangulation.match_noise_px`). Acts with
    ``covariance: following``. None: off."""
    covariance: Literal["following", "independent"] = "following"
    """How pixel errors are propagated into each measurement's covariance R: ``following``
    (the right match follows the template cut at the left centre: ``pixel_std`` moves the point
    sideways, ``match_std`` in depth) or ``independent`` (the paper: both image points have
    ``pixel_std``, independently)."""
    latency: float | None = Field(None, ge=0.0, le=0.5)
    """Declared processing latency (s): measurements are ready at the frame's ready time plus
    this. Default: one camera frame (each frame is processed while the next is captured)."""
    pipelined: Literal["auto", "process", "thread", "off"] = "auto"
    """With a latency of at least one frame, process each frame in a worker while the
    simulation renders the next (same results and simulated timing, less wall time):
    ``process`` (a child process), ``thread``, ``auto`` (a process for runs of 2 s or more on
    two or more cores, else a thread) or ``off``. ``true``/``false`` mean ``auto``/``off``."""

    @field_validator("pipelined", mode="before")
    @classmethod
    def _pipelined_bool(cls, value):
        if isinstance(value, bool):  # the older spelling
            return "auto" if value else "off"
        return value

    @model_validator(mode="after")
    def _floor_needs_following(self) -> PerceptionConfig:
        if self.match_floor_px is not None and self.covariance != "following":
            raise ValueError("match_floor_px acts with covariance: following (got "
                             f"{self.covariance!r})")
        return self

    @field_validator("targets")
    @classmethod
    def _unique(cls, value: list[str]) -> list[str]:
        if len(set(value)) != len(value):
            raise ValueError(f"targets are listed twice: {value}")
        return value

    @field_validator("colors")
    @classmethod
    def _unique_colors(cls, value: list[TargetColor]) -> list[TargetColor]:
        names = [c.target for c in value]
        if len(set(names)) != len(names):
            raise ValueError(f"a target has two colour models: {names}")
        return value

    def color_file(self, target: str) -> Path | Literal["auto"]:
        """The colour-model file of ``target``, or ``auto``."""
        for c in self.colors:
            if c.target == target:
                return c.file
        return self.color_model
