"""The 2-D hand tracker's scenario section (``trackers.<name>`` with ``kind: hand2d``).

Defaults are Menezes et al.'s Table 3 (CONDENSATION, N = 100, sigma_s = 36 over N_p = 30
model points, i.e. a *sum* of distances, penalty rho = 0.12 for static edges); the rest
(dynamics, detection, loss) are ours and documented per key. Units: px, rad, frames.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from humimic.perception.trackers.fields import Bins
from humimic.scenario.base import Section

CUES = ("shape", "motion", "colour", "skin")
HAND_TARGETS = ("right_hand", "left_hand")


class Hand2DConfig(Section):
    """Menezes sec. 5.1: a hand template tracked in one camera's images, state (u, v, s,
    theta): centre (px), hand width (px), in-plane rotation (rad)."""

    kind: Literal["hand2d"]
    camera: str | None = None
    """Eye camera (scene name, e.g. ``L_foveal``); None: the first rendered eye."""
    target: Literal[HAND_TARGETS] = "right_hand"
    """The hand it is scored against (ground truth); the tracker itself takes the moving
    skin blob that fits the hand template."""
    filter: Literal["condensation", "icondensation"] = "condensation"
    """``condensation`` (Table 3); ``icondensation`` adds skin blobs as importance function."""
    n_particles: int = Field(100, ge=1, le=5000)
    cues: tuple[Literal[CUES], ...] = ("shape", "motion", "skin")
    """Fused cues (eq. 7): ``shape`` (eq. 2 / 3), ``motion`` (with shape: eq. 4 / 5; alone
    not allowed), ``colour`` (eq. 6, one patch on the palm, reference updated by eq. 13),
    ``skin`` (added here: the skin posterior just inside against just outside the template,
    :mod:`humimic.perception.cues.skin`). The paper's Table 3 is ``[shape, motion]``; with
    ``skin`` in the lab_clutter room (Fig. 5, seeds 1/9/4): lost 21/22/29 % -> 10/11/9 % of
    the frames, centre RMSE 6.6/5.8/6.9 -> 2.4/3.3/2.5 px; another person behind the hand
    (menezes_hand_people): lost 35 -> 13 %, 0 identity switches either way."""
    edges: Literal["grey", "colour"] = "colour"
    """The shape cue's edges (also the detector's and the loss test's): Canny on the grey
    image (the paper) or on the colour gradient (the strongest channel's, as GEST's and TBP's
    ``edges``). Under other light a skin hand can match the grey wall behind it in grey level
    and lose its grey edges: menezes_hand_people with ``lighting.ambient: 0.1,
    lighting.diffuse: 0.3`` (3 s), the waving hand's template 21.8 px from the nearest grey
    edge against 2.8 px on colour edges. 3 s runs of menezes_hand_people, lost grey -> colour:
    16 -> 0 % (default light), 41 -> 23 % (that dim light), 27 -> 0 % (ambient 0.6, diffuse
    0.9), 47 -> 0 % at 3 m; more in the README (Any light). Cost: Canny on the colour
    gradient of the 125 x 147 px ROI 0.72 ms against 0.18 ms on grey, no change measurable
    in a whole tracking frame (``bench_hand2d.py --repeats 5``, wall, load 1.5: 4.29 / 4.07
    against the grey code's 4.19 ms)."""
    similarity: Literal["normal", "dt"] = "normal"
    """Edge distance along the template normals (eqs. 2, 4) or by distance transform (3, 5)."""
    sigma_s: float = Field(36.0, gt=0.0, le=1e4)
    """Shape likelihood's standard deviation (px), over the *sum* of the points' distances."""
    n_points: int = Field(30, ge=4, le=200)
    rho: float = Field(0.12, ge=0.0, le=100.0)
    """Eq. 4's penalty (px) for a static edge."""
    K: float = Field(0.5, gt=0.0, le=1.0)
    """Eq. 5's weight of the moving edges' distance transform (dt similarity)."""
    search_px: int = Field(10, ge=1, le=60)
    """Half length of the search along each normal (px)."""
    min_flow_px: float = Field(0.5, ge=0.0, le=20.0)
    """Optical flow (px/frame) above which an edge is moving."""
    sigma_c: float = Field(0.2, gt=0.0, le=10.0)
    """Colour likelihood's standard deviation over the Bhattacharyya distance (eq. 6); 0.2
    fused best on the Fig. 5 sequence (0.1: the colour cue overrode the shape)."""
    sigma_k: float = Field(0.15, gt=0.0, le=10.0)
    """Skin cue's standard deviation over ``D = 1 - (skin inside - skin outside)``."""
    bins: Bins = 16
    """Histogram bins per RGB channel (must divide 256)."""
    kappa: float = Field(0.05, ge=0.0, le=1.0)
    """Eq. 13's reference update rate."""
    dynamics: tuple[float, float, float, float] = (6.0, 6.0, 1.0, 0.05)
    """Random-walk standard deviations of (u, v, s, theta) per frame (px, px, px, rad)."""
    alpha: float = Field(0.3, ge=0.0, le=1.0)
    """ICONDENSATION: share of particles from the importance function."""
    beta: float = Field(0.6, ge=0.0, le=1.0)
    """ICONDENSATION: share from the dynamics (the rest from the prior)."""
    min_hand_px: float = Field(8.0, gt=0.0, le=200.0)
    """Smallest hand width (px) the detector starts on."""
    init_edge_px: float = Field(3.0, gt=0.0, le=30.0)
    """Detection: the hand template placed on a skin blob must lie within this mean edge
    distance (px) for the detectors to agree."""
    lost_edge_px: float = Field(4.0, gt=0.0, le=30.0)
    """Loss: the estimate's mean edge distance (px) above which a frame counts as bad ..."""
    lost_rim_odds: float = Field(2.0, ge=1.0, le=100.0)
    """... unless (with the ``skin`` cue) its rim still separates skin from background: the
    skin posterior just inside the template at least this many times that just outside
    (:func:`~humimic.perception.cues.skin.rim_separates`; a hand over a background of its own
    brightness has no grey-level rim). Relative, as the skin posterior's level on a hand
    depends on the skin tone: the absolute test it replaces (``1 - (inside - outside) <=
    0.5``, as GEST's ``lost_skin`` was; GEST's ``lost_rim_odds`` is this test now) declared a
    very dark hand lost while on it (menezes_fig5_hand, skin [0.25, 0.16, 0.11]: its shaded
    rim's inside 0.48-0.79)."""
    min_skin: float = Field(0.3, ge=0.0, le=1.0)
    """Loss: the least fraction of skin pixels inside the estimated hand."""
    lost_frames: int = Field(3, ge=1, le=1000)
    """Bad frames in a row after which the track is lost and detection starts again."""
    roi_margin_px: int = Field(12, ge=0, le=320)
    """Edges and flow are computed in the particles' bounding box plus this margin."""
    latency: float = Field(0.0, ge=0.0, le=1.0)
    """Declared processing latency (s) of the ``tracks2d`` messages."""

    @field_validator("cues")
    @classmethod
    def _cues(cls, v):
        if not v:
            raise ValueError("at least one cue is needed")
        if len(set(v)) != len(v):
            raise ValueError("a cue is listed twice")
        if "motion" in v and "shape" not in v:
            raise ValueError("motion filters the shape cue's edges: add shape")
        return v
