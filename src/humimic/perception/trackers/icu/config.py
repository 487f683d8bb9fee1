"""The ICU tracker's scenario section (``trackers.<name>`` with ``kind: icu``).

Defaults are Menezes et al.'s Table 4 (ICONDENSATION, N = 150, sigma_s = 1.5 over N_p = 15
points, two colour patches of 32 bins, sigma_c = 0.03, kappa 0.1 / 0.05); the rest (dynamics,
detection rate, loss, the state machine's thresholds) are ours, documented per key.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from humimic.perception.trackers.fields import Bins
from humimic.scenario.base import Section


class NearModule(Section):
    """Fig. 15's distance switch (:mod:`humimic.perception.trackers.icu.modules`): another
    tracker of the scenario takes over while the recognised tutor is near."""

    module: str
    """Name (a key of ``trackers:``) of the near module, e.g. a ``tbp`` or ``gest`` tracker;
    it gets frames only while the tutor is near."""
    enter_m: float = Field(1.5, gt=0.0, le=20.0)
    """Switch to the near module below this distance (m; the pinhole range of the estimate's
    head width)."""
    leave_m: float = Field(1.8, gt=0.0, le=20.0)
    """Back to ICU above this distance (m)."""
    hold_s: float = Field(0.25, ge=0.0, le=10.0)
    """The tutor counts as recognised and tracked until the ICU tracker has not been on a
    recognised face for this long (its losses of a few frames do not reset the module)."""

    @field_validator("leave_m")
    @classmethod
    def _band(cls, v, info):
        enter_m = info.data.get("enter_m", 0.0)
        if v < enter_m:
            raise ValueError(f"leave_m must be at least enter_m ({enter_m:g})")
        return v


class IcuConfig(Section):
    """Menezes sec. 5.2: one person (the tutor) tracked in one camera's images, state
    (u, v, s): head centre (px) and head width (px)."""

    kind: Literal["icu"]
    camera: str | None = None
    """Eye camera (scene name, e.g. ``L_foveal``); None: the first rendered eye."""
    identity: str | None = None
    """The tutor's face (a :data:`humimic.world.faces.IDENTITY_NAMES` name); None: the
    scenario's ``human.identity``."""
    recognition: bool = False
    """Weigh faces by the eigenface recogniser's probability of the tutor (eq. 12). It is
    trained on the ``enrolled`` identities on first use (minutes; then cached)."""
    enrolled: int = Field(4, ge=2, le=16)
    """How many identities the recogniser knows: the tutor, the other people in the room,
    then the first names of :data:`IDENTITY_NAMES`."""
    views: int = Field(40, ge=5, le=500)
    """Rendered training views per identity (the recogniser's training cost: ~0.1 s each,
    once per machine, then cached)."""
    min_confidence: float = Field(0.5, ge=0.0, le=1.0)
    """Recognition probability of the tutor a face needs to start the tracker."""
    n_particles: int = Field(150, ge=1, le=5000)
    cues: tuple[Literal["shape", "colour"], ...] = ("shape", "colour")
    """Fused cues (eq. 7): the head-and-shoulders silhouette (eq. 3) and the head and torso
    colour (eq. 6); the colour references are kept either way (the loss test uses them)."""
    sigma_s: float = Field(1.5, gt=0.0, le=100.0)
    """Shape likelihood's standard deviation (px) over the *mean* distance (eq. 3)."""
    n_points: int = Field(15, ge=4, le=200)
    sigma_c: float = Field(0.03, gt=0.0, le=10.0)
    bins: Bins = 32
    kappa: tuple[float, float] = (0.1, 0.05)
    """Eq. 13's reference update rates of the head and torso patches."""
    alpha: float = Field(0.3, ge=0.0, le=1.0)
    beta: float = Field(0.6, ge=0.0, le=1.0)
    dynamics: tuple[float, float, float] = (6.0, 6.0, 1.0)
    """Random-walk standard deviations of (u, v, s) per frame (px)."""
    detect_every: int = Field(1, ge=1, le=100)
    """While tracking, the face detector runs every this many frames, only around the
    estimate (~1 ms CPU); while searching, every frame."""
    redetect_after: int = Field(6, ge=0, le=1000)
    """While tracking, after this many face searches in a row found no face taken for the
    tutor on the estimate (within 0.3 face widths; none in the window, or one beside it),
    search the whole frame (~16 ms CPU a frame at
    320 x 240) until one is found, then restart there (the filter and the colour references):
    a cloud drifted onto clutter, so that the window misses the face's place or size while the
    colour loss test does not fire, is put back on the tutor; 0: never. Measured, Fig. 15 seed
    11 in ``lab_clutter``: without it the cloud stuck on the shelves above-left of the nearing
    head (centre error median 23.0 px, no switch to the near module)."""
    search: Literal["skin", "whole"] = "skin"
    """Where faces are searched while nobody is tracked: ``skin`` -- around the skin blobs of
    head size (the scenario's skin model; ~1 ms per blob instead of ~16 ms CPU for the whole
    320 x 240 frame); ``whole`` -- the whole frame at every size."""
    min_face_px: int = Field(20, ge=8, le=200)
    face_scale_factor: float = Field(1.2, gt=1.0, le=2.0)
    """The tracker's face searches' pyramid step (``detectMultiScale``'s scaleFactor; the
    recogniser is trained with the detector's 1.1). Measured, 3 seeds of Figs. 9 and 10 with
    detection every frame: 1.2 instead of 1.1 costs 17-20 % less CPU per frame, centre error
    median 3.9 -> 3.9 px (Fig. 10), 3.1 -> 5.0 px (Fig. 9)."""
    face_fit_px: int = Field(0, ge=0, le=200)
    """While tracking, shrink the face window so the smallest expected face is about this
    many pixels (:attr:`~humimic.perception.faces.detect.DetectorParams.fit_px`: ~25 % less
    time per frame, noisier boxes and ~1-4 px more centre error); 0: never."""
    lost_colour: float = Field(0.5, gt=0.0, le=1.0)
    """Loss: Bhattacharyya distance (the worse of head and torso) above which a frame is
    bad."""
    lost_frames: int = Field(4, ge=1, le=1000)
    latency: float = Field(0.0, ge=0.0, le=1.0)
    near: NearModule | None = None
    """Fig. 15: the module that takes over near the robot (None: ICU at every distance)."""

    @field_validator("cues")
    @classmethod
    def _cues(cls, v):
        if not v or len(set(v)) != len(v):
            raise ValueError("give each cue once, at least one")
        return v
