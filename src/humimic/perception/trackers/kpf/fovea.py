"""Our extension (issue 14; not in the paper, whose conclusion lists active vision as future
work): the kpf likelihood with a second view of the arms through the same eye's narrow
(foveal) camera, the eye's gaze on the tracker's own arm estimate (``trackers.<kpf>.fovea``).

The wide eye (100 deg, f = 134 px) sees the person at 2 m with a 4.6 px wide forearm; the
foveal camera of the same eye (24 deg, f = 753 px), coaxial with it, sees the arm 5.6x larger
when the eye looks at it (the scenario's ``mimic.gaze`` with ``tracker: <kpf>``, ``target:
right_elbow``). Both images are taken at the same instant from the same eye; given the pose
they are taken as independent observations, so their likelihoods multiply (Bayes' rule for
conditionally independent measurements), and eq. 10's product over limbs gains, for each
foveal part ``l``, the foveal view's factor of that limb:

    log p(y_w, y_f | x) = sum_l T_w(l) + w_f sum_{l in fovea} T_f(l)        (Schmidt eq. 10, x2)

with ``T(l) = 1/N_l sum_c -e_{c,l}^2 / (2 sigma_c^2)`` (eq. 9 with eq. 10's balancing factor)
computed in each view by :class:`~humimic.perception.trackers.kpf.likelihood.Likelihood`, and
``w_f`` (``fovea.weight``) a tempering of the second view (1: the plain product). A limb off
the foveal image costs 1 in every cue there, as in the wide view. The colour references are
the wide view's (eq. 7 adapts them from the wide view's best mode): both cameras see the same
clothes through the same renderer.

Profiled on Table 1's frames (``schmidt-depth-profile --set cameras.which=foveal --gaze
right_elbow right_wrist``, the eye on the true arm): in the hold, the truth's elbow flip and
double flip cost 1.0-3.0 nats in the foveal view (the wide eye: -0.00-0.33), the wrist flip
0.25 (side) / 0.33 (angular) nats (the wide eye 0.01). Tracked (``schmidt_table1_fovgaze``,
with the flip-branch decision, (1000, 3), seeds 0-9): angular pointing 65 mm (Table 1's kpf
198), side 51 (40); with the hand's skin points off the narrow image read in the wide view
(``skin_in_view: search``, :class:`FovealView`; seeds 0-9) side 38, angular 74; see
docs/schmidt_kpf_notes.md, "Round of 29 Nov, i14-fovgaze" and "Round of 29 Nov (2), i14-fside".

Which evaluations multiply in the foveal view (``fovea.use``; 29 Nov, ``i14-fang``): ``all``;
``decision``, only the flip-branch decision's (:func:`decision_view`; the search, i.e. mean
shift, reweighting and refinement, on the wide view alone); ``moving``, the search's too while
the estimated arm moves (:func:`wrist_step` above ``moving_m`` between the last two estimates).

Both eyes' foveal cameras (``fovea.cameras: [L_foveal, R_foveal]``, ``cameras.eyes: stereo``;
29 Nov, ``i14-stereo``): each narrow view, with its own camera pose, is one more conditionally
independent factor, ``+ w_f sum_v sum_{l in fovea} T_v(l)``. The left eye's two cameras are
coaxial (a flip mirrored in depth along the eye's ray images alike in both); the right eye,
70 mm away, sees the flips 250-470 mm apart in depth ~3-6 px apart at 2 m (f = 753 px):
stereo breaks the ties the coaxial views leave (``scenarios/schmidt_table1_stereo.yaml``,
weight 1.5: angular pointing 60 mm on seeds 10-19 against the left eye's 78, but side 50.5
against 34.5; docs/schmidt_kpf_notes.md, "Round of 29 Nov (5), i14-stereo").
"""

from __future__ import annotations

from contextlib import contextmanager, nullcontext

import numpy as np

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.cues import _DISC
from humimic.perception.trackers.kpf.likelihood import Evaluation, Likelihood


def two_view_terms(terms_wide: np.ndarray, terms_fovea: np.ndarray, in_fovea: np.ndarray,
                   weight: float) -> np.ndarray:
    """Eq. 10's per-part log factors of two conditionally independent views: the wide view's
    ``(N, parts)`` terms plus ``weight`` times the foveal view's on the parts ``in_fovea``
    ``(parts,) bool``; their row sums are ``log p(y_w | x) + weight log p_fovea(y_f | x)``."""
    return terms_wide + weight * np.where(in_fovea, terms_fovea, 0.0)


def parts_in_view(uv: np.ndarray, valid: np.ndarray, width: int, height: int,
                  margin: float) -> np.ndarray:
    """``(P,)`` the parts whose outline ``uv (P, V, 2)`` (px; ``valid (P,)``) lies wholly inside
    the ``width x height`` image at least ``margin`` px from its border. (A cue point off the
    image reads no response (:mod:`~humimic.perception.trackers.kpf.cue_costs`), the same for
    the truth and a wrong pose, so a limb half out of the narrow image pulls the estimate
    towards poses that put it inside; scoring only the limbs in view at the last estimate
    avoids that.)"""
    u, v = uv[..., 0], uv[..., 1]
    inside = (u >= margin) & (v >= margin) & (u <= width - 1 - margin) & (v <= height - 1 - margin)
    return np.asarray(valid, bool) & np.all(inside, axis=-1)


def disc_in_view(centre: np.ndarray, axes: np.ndarray, angle: np.ndarray, width: int,
                 height: int) -> np.ndarray:
    """``(N, E)`` the share of the skin cue's sample points (:data:`~humimic.perception.
    trackers.kpf.cues._DISC`, rounded to pixels as the cost pass does) of image ellipses
    (centres ``(N, E, 2)``, semi-axes ``(N, E, 2)``, angles ``(N, E)``) inside a ``width x
    height`` image."""
    c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
    x, y = _DISC[:, 0] * axes[..., :1], _DISC[:, 1] * axes[..., 1:]
    u = np.rint(centre[..., :1] + c * x - s * y)
    v = np.rint(centre[..., 1:] + s * x + c * y)
    return np.mean((u >= 0) & (v >= 0) & (u < width) & (v < height), axis=-1)


def in_view_skin(cost: np.ndarray, share: np.ndarray, cost_wide: np.ndarray) -> np.ndarray:
    """Schmidt eq. 8 in the foveal view with its sample points off the narrow image read in
    the wide one: the cost ``1 - f`` of a skin fraction ``f`` counted over all points
    (off-image ones reading no skin), ``share`` of them inside, becomes ``1 - f - (1 -
    share) (1 - c_w)`` with ``c_w`` (``cost_wide``) the same hand's cost in the wide view:
    the points the narrow camera does not see count as skin as often as the wide camera
    sees the hand's (a hand wholly off the narrow image costs its wide-view cost)."""
    return cost - (1.0 - share) * (1.0 - cost_wide)


class FovealView(Likelihood):
    """:class:`Likelihood` of the foveal view, whose narrow image shows only part of the arm
    (at rest the hanging hand half below it): with ``skin_in_view`` the hands' skin cue
    reads its sample points off the image in the wide view (:func:`in_view_skin`; the wide
    view's skin costs given by :meth:`wide_skin` before each evaluation). Counted over all
    points (eq. 8 as in the wide view), the hand half off the image costs ~0.6 at the truth
    and less wherever a pose lifts it into the image: the foveal view pulled the resting
    hand 20-45 mm up (seed 4 side)."""

    def __init__(self, body, intrinsics, cfg, skin_in_view: bool = False):
        super().__init__(body, intrinsics, cfg)
        self.skin_in_view = skin_in_view
        self.skin_cols = np.asarray(body.layout.ellipsoid_idx, np.intp)[self.skin_js]
        self.cost_wide: np.ndarray | None = None

    def wide_skin(self, cost_wide: np.ndarray | None) -> None:
        """The wide view's skin costs ``(N, parts)`` of the poses evaluated next."""
        self.cost_wide = cost_wide

    def observed(self, planes: np.ndarray, ellipses) -> None:
        if not self.skin_in_view or not len(self.skin_js) or self.cost_wide is None:
            return
        centre, axes, angle = ellipses
        j, cols = self.skin_js, self.skin_cols
        share = disc_in_view(centre[:, j], axes[:, j], angle[:, j], self.intr.width,
                             self.intr.height)
        planes[3][:, cols] = in_view_skin(planes[3][:, cols], share, self.cost_wide[:, cols])


def wrist_step(body, q: np.ndarray, q_prev: np.ndarray, prefixes: tuple[str, ...]) -> float:
    """The largest distance (m) an arm's wrist (``prefixes``: ``r``, ``l``) moved between the
    poses ``q_prev`` and ``q (14,)``: whether the estimated arm moves (``use: moving``)."""
    pose = body.forward(np.stack([np.asarray(q_prev, float), np.asarray(q, float)]))
    return max((float(np.linalg.norm(np.diff(pose.joint(f"{p}_wrist"), axis=0)))
                for p in prefixes), default=0.0)


class FovealLikelihood(Likelihood):
    """:class:`Likelihood` of the wide view (the tracker's camera) times the foveal views'
    factors of the ``parts`` (:func:`two_view_terms`, once per view: conditionally independent
    views multiply). ``fovea_intrinsics`` is one narrow camera's intrinsics or a sequence of
    them (e.g. both eyes' foveal cameras: stereo); the foveal frames are
    given before each tracker step by :meth:`look_views` (:meth:`look` for the first camera;
    until then, and after ``look(None, None)``, the wide view alone)."""

    def __init__(self, body, intrinsics, cfg, fovea_intrinsics, parts: tuple[str, ...],
                 weight: float = 1.0, use: str = "all", decision_weight: float | None = None,
                 moving_m: float = 0.02, skin_in_view: str | None = None):
        super().__init__(body, intrinsics, cfg)
        if use not in ("all", "decision", "moving"):
            raise ValueError(f"fovea use {use!r}: 'all', 'decision' or 'moving'")
        unknown = sorted(set(parts) - set(self.parts))
        if unknown:
            raise ValueError(f"fovea parts {unknown} are not body parts; parts: {self.parts}")
        intrs = (fovea_intrinsics if isinstance(fovea_intrinsics, (list, tuple))
                 else [fovea_intrinsics])
        self.foveas = [FovealView(body, i, cfg, skin_in_view is not None) for i in intrs]
        """One :class:`FovealView` per foveal camera."""
        self.skin_in_view = skin_in_view
        """``fovea.skin_in_view``: None, ``search`` (in the filter's evaluations, not in the
        fixed-sigma ones, ``floors``, of the branch decision and the refinement) or ``all``."""
        self.in_fovea = np.array([p in parts for p in self.parts])
        self.weight = float(weight)
        self.decision_weight = self.weight if decision_weight is None else float(decision_weight)
        """The foveal factors' exponent in the flip-branch decision's evaluations."""
        self.views: list[tuple | None] = [None] * len(self.foveas)
        """Per foveal camera (maps, T_cam_base) of its frame, or None."""
        self.scored_views = [self.in_fovea] * len(self.foveas)
        """Per foveal camera (parts,) the parts scored in its frame (:meth:`look_views`)."""
        self.use = use
        """``all``: every evaluation sees both views; ``decision``: only those inside
        :meth:`deciding` (the flip-branch decision's), the others the wide view alone."""
        self._deciding = False
        self.moving_m = float(moving_m)
        self.moving = False
        """``use: moving``: whether the last estimate's arm moved (:meth:`look_views`)."""
        self.sides = tuple(sorted({p[0] for p in parts}))

    @property
    def view(self) -> tuple | None:
        """The first foveal camera's (maps, T_cam_base) present, or None (none is)."""
        return next((v for v in self.views if v is not None), None)

    @property
    def scored(self) -> np.ndarray:
        """(parts,) the parts scored in any foveal frame."""
        return np.any(self.scored_views, axis=0)

    @contextmanager
    def deciding(self):
        """The evaluations within see the foveal view also with ``use: decision``."""
        before, self._deciding = self._deciding, True
        try:
            yield self
        finally:
            self._deciding = before

    @property
    def active(self) -> bool:
        """Whether an evaluation now multiplies in the foveal view."""
        return self.view is not None and (self.use == "all" or self._deciding
                                          or (self.use == "moving" and self.moving))

    def look(self, maps, T_cam_base: np.ndarray | None, q_ref: np.ndarray | None = None,
             margin: float | None = None, q_prev: np.ndarray | None = None) -> None:
        """:meth:`look_views` with the first foveal camera's frame ``(maps, T_cam_base)``
        (None: none) and no frame of the others."""
        first = None if maps is None else (maps, T_cam_base)
        self.look_views([first] + [None] * (len(self.foveas) - 1), q_ref, margin, q_prev)

    def look_views(self, views, q_ref: np.ndarray | None = None, margin: float | None = None,
                   q_prev: np.ndarray | None = None) -> None:
        """The foveal frames' cue maps and camera poses for the next evaluations, ``views``
        one ``(maps, T_cam_base)`` or None per foveal camera; with ``margin`` (px) only those
        of the parts wholly inside each image (:func:`parts_in_view`) at the pose ``q_ref
        (14,)`` (the last estimate) are scored in it. ``use: moving``: every evaluation sees
        them if a foveal arm's wrist moved more than ``moving_m`` from ``q_prev`` (the
        estimate before) to ``q_ref``, else only the decision's."""
        if len(views) != len(self.foveas):
            raise ValueError(f"{len(views)} foveal views for {len(self.foveas)} cameras")
        self.views = list(views)
        self.moving = (self.use == "moving" and q_ref is not None and q_prev is not None
                       and wrist_step(self.body, q_ref, q_prev, self.sides) > self.moving_m)
        self.scored_views = [self.in_fovea] * len(self.foveas)
        if margin is None or q_ref is None:
            return
        pose = self.body.forward(np.asarray(q_ref)[None])
        for k, (fov, v) in enumerate(zip(self.foveas, self.views, strict=True)):
            if v is not None:
                i = fov.intr
                out = bm.project(self.body, pose, i, v[1]).outline
                self.scored_views[k] = self.in_fovea & parts_in_view(
                    out.uv[0], out.valid[0], i.width, i.height, margin)

    def evaluate(self, q: np.ndarray, maps, T_cam_base: np.ndarray,
                 floors: bool = False) -> Evaluation:
        ev = super().evaluate(q, maps, T_cam_base, floors=floors)
        if not self.active:
            return ev
        read_wide = self.skin_in_view == "all" or (self.skin_in_view == "search" and not floors)
        w = self.decision_weight if self._deciding else self.weight
        terms = ev.terms
        for fov, v, scored in zip(self.foveas, self.views, self.scored_views, strict=True):
            if v is None:
                continue
            fov.wide_skin(ev.cost["skin"] if read_wide else None)
            terms = two_view_terms(terms, fov.evaluate(q, *v, floors=floors).terms, scored, w)
            fov.wide_skin(None)
        return Evaluation(ev.cost, terms, ev.colours)

    def share_references(self, references: dict[str, np.ndarray]) -> None:
        super().share_references(references)
        for fov in self.foveas:
            fov.share_references(references)


def decision_view(lik):
    """The context in which the flip-branch decision evaluates ``lik``: with the foveal view
    for a :class:`FovealLikelihood` (``fovea.use: decision`` too), as it is otherwise."""
    return lik.deciding() if isinstance(lik, FovealLikelihood) else nullcontext()
