"""The pose likelihood of Schmidt, Fritsch & Kwolek (eqs. 9-10) for N particles at once.

Every particle's body model is projected (:func:`humimic.bodymodel.limb_view.limb_view`, the
compiled subset of :func:`~humimic.bodymodel.project` the cues need), the feature points of all
limbs are sampled from the frame's :class:`~humimic.perception.trackers.kpf.cues.CueMaps` and
each limb's response becomes a cost ``e`` in one compiled pass for all cues
(:func:`~humimic.perception.trackers.kpf.cue_costs.cue_costs`), and

    log p(y | x) = sum_l 1/N_l sum_{c in cues(l)} -e_{c,l}^2 / (2 sigma_c^2)        (eqs. 9-10)

with ``N_l`` the number of cues on limb ``l`` (the balancing factor). ``sigma_c`` is the spread
of cue ``c``'s costs over the particles (standard deviation), floored by the configured value.
A limb off the image or seen end-on costs 1 in every cue.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic import bodymodel as bm
from humimic.bodymodel.limb_view import limb_view
from humimic.perception.trackers.kpf import cues as C
from humimic.perception.trackers.kpf.cue_costs import cue_costs, eq10_coefficients, eq10_terms
from humimic.perception.trackers.kpf.frame_cues import FrameCues, sample_box
from humimic.perception.trackers.kpf.skin_ring import ring_log_term, ring_pad, ring_skin

CUE_NAMES = ("edge", "ridge", "colour", "skin")
#: The colour polygons are pulled towards the limb's axis by this fraction of its half-width.
BAND_SHRINK = 0.2


def limb_type(part: str) -> str:
    """``torso``, ``head``, ``upper_arm``, ``forearm`` or ``hand`` of a part name."""
    return part[2:] if part[:2] in ("r_", "l_") else part


@dataclass
class Evaluation:
    """Per-particle costs ``(N, parts)`` per cue (NaN where the cue is not used on the part),
    the log-likelihoods and the band colours (for eq. 7's adaptation)."""

    cost: dict[str, np.ndarray]
    terms: np.ndarray
    """(N, parts) each part's eq.-10 factor (log): ``1/N_l sum_c log p(c, l)``."""
    colours: dict[str, np.ndarray]
    """Part name -> (N, B, 3) mean band colours."""

    @property
    def log_lik(self) -> np.ndarray:
        """(N,) eq. 10 (log)."""
        return self.terms.sum(axis=1)

    def mean_cost(self, i: int) -> float:
        """Mean cost over the used (part, cue) pairs of particle ``i``."""
        vals = np.concatenate([c[i][np.isfinite(c[i])] for c in self.cost.values()])
        return float(vals.mean()) if len(vals) else 1.0


class Likelihood:
    """Eqs. 9-10 for one body model, camera and cue configuration ``cfg``
    (:class:`~humimic.perception.trackers.kpf.config.KpfConfig`)."""

    def __init__(self, body: bm.BodyModel, intrinsics, cfg):
        self.body, self.intr, self.cfg = body, intrinsics, cfg
        self.parts = body.part_names
        self.use = {p: tuple(getattr(cfg.cues, limb_type(p))) for p in self.parts}
        self.floor = {c: getattr(cfg.sigma, c) for c in CUE_NAMES}
        self.bands = {p: cfg.bands_torso if limb_type(p) == "torso" else cfg.bands_arm
                      for p in self.parts}
        self.used = {c: np.array([c in self.use[p] for p in self.parts]) for c in CUE_NAMES}
        """Cue -> (parts,) bool: the cue is configured on the part."""
        self.any_used = {c: bool(u.any()) for c, u in self.used.items()}
        n_l = np.array([max(len(self.use[p]), 1) for p in self.parts], float)
        self.balance = {c: self.used[c] / n_l for c in CUE_NAMES}
        """Eq. 10's 1 / N_l where the cue is used, else 0."""
        self.references: dict[str, np.ndarray] = {}
        """Part name -> (B, 3) adapted mean colours (eq. 7); empty until :meth:`adapt`."""
        lay = body.layout
        self.limbs = [self.parts[i] for i in lay.cone_idx]
        """The cone parts, in the order of the limb features."""
        self.limb_cue = np.array([[c in self.use[p] for c in ("edge", "ridge")]
                                  for p in self.limbs], np.bool_).reshape(-1, 2)
        """(cones, 2) the edge / ridge cue is configured on the cone."""
        self.limb_bands = np.array([self.bands[p] if "colour" in self.use[p] else 0
                                    for p in self.limbs], np.intp)
        """(cones,) the cone's colour bands (0: no colour cue)."""
        self.colour_limbs = [(j, p) for j, p in enumerate(self.limbs) if self.limb_bands[j]]
        """(position among the cones, part name) of the limbs with the colour cue."""
        self.refs = np.zeros((len(self.limbs), max(self.limb_bands, default=0), 3))
        """(cones, B_max, 3) :attr:`references` laid out for the cost pass."""
        self.has_ref = np.zeros(len(self.limbs), np.bool_)
        ell = [self.parts[i] for i in lay.ellipsoid_idx]
        self.skin_js = np.array([j for j, p in enumerate(ell) if "skin" in self.use[p]], int)
        """Positions (among the ellipsoids) of the parts with the skin cue."""
        self.ell_skin = np.isin(np.arange(len(ell)), self.skin_js)
        """(ellipsoids,) the skin cue is configured on the ellipsoid."""
        self.balance_planes = np.stack([self.balance[c] for c in CUE_NAMES])
        self._coef: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        """Sigmas -> :func:`~humimic.perception.trackers.kpf.cue_costs.eq10_coefficients`."""
        self.hand_js = np.array([j for j in self.skin_js if limb_type(ell[j]) == "hand"], int)
        """Positions (among the ellipsoids) of the hands with the skin cue (``skin_ring``)."""

    def evaluate(self, q: np.ndarray, maps: C.CueMaps | FrameCues, T_cam_base: np.ndarray,
                 floors: bool = False) -> Evaluation:
        """Costs and log-likelihoods of full states ``q (N, 14)``; ``maps`` the frame's maps,
        or a :class:`FrameCues` that computes them where these particles' points fall;
        ``floors``: the sigmas are the configured floors whatever ``sigma_from_spread`` (one
        objective for any batch, e.g. a local search's few candidates)."""
        cfg = self.cfg
        view = limb_view(self.body, self.body.forward(q), self.intr, T_cam_base)
        ellipses = view.ellipses
        ring = cfg.skin_ring if len(self.hand_js) else None
        if isinstance(maps, FrameCues):
            lo, hi = sample_box(view, ellipses)
            pad = 0.0 if ring is None else ring_pad(ellipses[1][:, self.hand_js], ring)
            maps = maps.covering(lo - pad, hi + pad)
        planes, got = cue_costs(maps, view, self.limb_cue, self.limb_bands, self.refs,
                                self.has_ref, self.ell_skin, len(self.parts), cfg.edge_points,
                                cfg.ridge_points, BAND_SHRINK)
        self.observed(planes, ellipses)
        cost = dict(zip(CUE_NAMES, planes, strict=True))
        colours = {p: got[:, j, :self.bands[p]] for j, p in self.colour_limbs}
        terms = self._terms(planes, cost, floors)
        if ring is not None:   # our extension: the hands' skin surround (kpf/skin_ring.py)
            j = self.hand_js
            centre, axes, angle = ellipses
            s = ring_skin(maps, centre[:, j], axes[:, j], angle[:, j], ring)
            s = np.where(view.valid[:, view.ellipsoid_idx[j]], s, 0.0)
            terms[:, np.asarray(view.ellipsoid_idx)[j]] += ring_log_term(s, self.floor["skin"])
        return Evaluation(cost, terms, colours)

    def observed(self, planes: np.ndarray, ellipses) -> None:
        """A hook for a view that sees only part of the body (the foveal view,
        :class:`~humimic.perception.trackers.kpf.fovea.FovealView`): may rewrite the cost
        ``planes (cues, N, parts)`` in place (here: nothing; eqs. 1-8 as they are)."""

    def sigmas(self, cost: dict[str, np.ndarray], floors: bool = False) -> dict[str, float]:
        """Eq. 9's ``sigma_c``: the spread of each cue's costs over the particles (mean over
        parts of the standard deviation), floored by the configured value (``floors``: the
        floor alone)."""
        out = {}
        for c, e in cost.items():
            floor = self.floor[c]
            used = self.used[c]
            if self.cfg.sigma_from_spread and not floors and used.any() and len(e) > 1:
                out[c] = max(float(np.mean(np.std(e[:, used], axis=0))), floor)
            else:
                out[c] = floor
        return out

    def combine(self, cost: dict[str, np.ndarray], floors: bool = False) -> np.ndarray:
        """Schmidt eqs. 9-10 per part ``l``: ``1/N_l sum_c -e^2 / (2 sigma_c^2)``, ``(N, parts)``
        (their sum over parts is the pose's log-likelihood; ``floors``: :meth:`sigmas`')."""
        return self._terms(np.stack([cost[c] for c in CUE_NAMES]), cost, floors)

    def _terms(self, planes: np.ndarray, cost: dict[str, np.ndarray], floors: bool
               ) -> np.ndarray:
        sig = self.sigmas(cost, floors)
        key = tuple(sig[c] for c in CUE_NAMES)
        if key not in self._coef:
            if len(self._coef) > 64:     # sigmas from the spread: new ones every evaluation
                self._coef.clear()
            self._coef[key] = eq10_coefficients(self.balance_planes, key)
        return eq10_terms(planes, *self._coef[key])

    def adapt(self, colours: dict[str, np.ndarray]) -> None:
        """Schmidt eq. 7 from the best mode's band colours ``{part: (B, 3)}``:
        ``C_ref = alpha C_mode + (1 - alpha) C_ref`` (the first call sets them)."""
        a = self.cfg.adapt
        for p, c in colours.items():
            ref = self.references.get(p)
            self.references[p] = c.copy() if ref is None else a * c + (1 - a) * ref
        self.share_references(self.references)

    def share_references(self, references: dict[str, np.ndarray]) -> None:
        """Use ``references`` (another likelihood's :attr:`references`, or our own)."""
        self.references = references
        for j, p in self.colour_limbs:
            self.has_ref[j] = p in references
            if self.has_ref[j]:
                self.refs[j, :self.bands[p]] = references[p]
