"""Which blob is which target: identities of same-coloured blobs (head and hands are skin).

The detector (:mod:`humimic.perception.blobs.detection`) finds blobs of one colour one by one and
cannot tell which body part each is. Identities are decided jointly for both eyes, whenever the
set of tracked blobs changes or a new blob has settled, as the cheapest assignment of blobs to
targets under:

* image rules, per eye. The person faces the robot, so *their* right hand appears on the
  image's left (it is at +y in the robot base frame):

  - the head is the largest skin blob: ``+1`` per hand blob larger than the head blob;
  - the right hand is left of the left hand: ``+1`` when not;
  - the right hand is left of the head and the left hand right of it: ``+0.5`` each when not;

* stereo, per target named in both eyes. Its two blob centres must be roughly corresponding
  points: ``+2`` when their triangulation reprojects further than ``gate`` blob standard
  deviations from either centre (Mahalanobis, blob shape covariance) or lies outside the depth
  range, ``-1`` when consistent (so one object gets one name in both eyes). A consistent pair
  also gives the blob's metric size, its "sigma radius" ``det(Sigma)^(1/4) z / f`` (m): the
  avatar's head (ellipsoid half-axes 78 x 115 mm seen from the front) measures ~47 mm, a hand
  (45 x 80 mm palm-on, 22 x 80 mm edge-on) 20-35 mm: up to ``+1`` against a name, graded by
  the likelihood ratio of head against hand size with the reading's uncertainty growing with
  depth (:mod:`humimic.perception.blobs.sizes`: the full rule once the Bayes factor against
  the name reaches 3). This names a lone blob, which the image rules cannot. A blob cut by the
  image border (``Blob.clipped``) is only part of its object: its reading is a lower bound of
  its size, never "too small to be the head" (area or size rule), so a head in a corner of a
  foveal view stays the head;
* continuity: ``-keep`` per blob that keeps its current identity, so tracked blobs keep their
  names (one rule against is not enough to swap; two are);
* locked names (our extension): a blob whose name was sure and whose region of interest has
  not touched another same-coloured blob's since (:func:`~humimic.perception.blobs.em_blobs.
  rois_overlap`), or touched it while every frame's step kept it on its own object
  (:func:`stayed_on_own_blob`), is the same object, whatever the rules say: EM cannot have
  swapped it. The cheapest assignment is chosen among those that keep every locked name. The
  image rules assume a person facing the robot; one who turns round shows the hands mirrored,
  and without the lock the rules renamed the tracked left hand the right one (ude_cmu_turn:
  31 % of the right hand's reports false). Locked names that break every side rule in both
  eyes while the mirrored rules hold show the person turned round (:func:`turned_round`,
  judged on the names the locks fix, :func:`fixed_names`, with the head seen); the perception
  core then applies the mirrored rules (``away``) until locked names show the reverse or the
  person is lost.

Between events identities follow the tracker's blobs (continuity alone), so hands may cross.
Each target also gets a *margin*: how much more evidence cost (without continuity) the cheapest
assignment that names it differently has. A margin of 0 means the evidence cannot tell (e.g. a
lone blob seen by one eye), a negative one that it disagrees with the names kept (or locked);
the perception stage publishes a target only when its margin is large enough, so a locked name
the rules contradict is kept but not vouched for.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from humimic.perception.blobs.sizes import SIZE_SD_FLOOR_M, radius_sd_m, size_cost
from humimic.perception.blobs.stereo import StereoRig

AREA_RULE = 1.0
ORDER_RULE = 1.0
SIDE_RULE = 0.5
STEREO_RULE = 2.0
PAIR_BONUS = 1.0
SIZE_RULE = 1.0
KEEP = 0.75
HANDS = ("right_hand", "left_hand")
#: Image-rule violations (both eyes) of locked names, none under the other facing, that show
#: a person turned round (:func:`turned_round`).
TURN_RULES = 2.0
#: A blob whose region touches another same-coloured blob's keeps its name (held aside, see
#: :func:`stayed_on_own_blob`) while each frame moves it at most this fraction of its distance
#: to the nearest other blob's last centre: EM handing it to the other object moves it there.
OWN_BLOB_RATIO = 1.0 / 3.0


@dataclass(frozen=True)
class Blob:
    """A tracked blob in one eye: tracker slot, centre (px) and shape covariance (px^2)."""

    slot: int
    centre: np.ndarray
    cov: np.ndarray
    clipped: bool = False
    """The blob's 2-sigma ellipse reaches past the image border: it is only part of its object
    (a head cut by the border looks smaller than it is, see :func:`clipped_by_border`)."""

    @property
    def area(self) -> float:
        """Proportional to the ellipse's area: sqrt(det Sigma) (px^2)."""
        return float(np.sqrt(max(np.linalg.det(self.cov), 0.0)))


@dataclass(frozen=True)
class PairEvidence:
    """Stereo evidence for every (left blob, right blob) pair."""

    inconsistent: np.ndarray
    """(n_left, n_right) bool: the two centres cannot be one object."""
    radius_m: np.ndarray
    """(n_left, n_right) metric sigma radius (m) of consistent pairs, NaN otherwise."""
    clipped: np.ndarray | None = None
    """(n_left, n_right) bool: either blob is cut by its image border (its radius is then
    only a lower bound)."""
    radius_sd_m: np.ndarray | None = None
    """(n_left, n_right) standard deviation (m) of each radius reading
    (:func:`~humimic.perception.blobs.sizes.radius_sd_m` at its depth); None: the floor."""


def image_rule_cost(assigned: dict[str, Blob], away: bool = False) -> float:
    """Rule violations of one eye's assignment ``{target: blob}`` (see the module docstring);
    ``away``: for a person with the back to the robot, whose hands the image shows mirrored
    (the right hand right of the left hand and of the head)."""
    cost = 0.0
    head = assigned.get("head")
    right, left = assigned.get("right_hand"), assigned.get("left_hand")
    if away:
        right, left = left, right
    for hand in (right, left):  # a head cut by the border may look smaller than a hand
        if (head is not None and hand is not None and not head.clipped
                and hand.area > head.area):
            cost += AREA_RULE
    if right is not None and left is not None and right.centre[0] > left.centre[0]:
        cost += ORDER_RULE
    if head is not None:
        if right is not None and right.centre[0] > head.centre[0]:
            cost += SIDE_RULE
        if left is not None and left.centre[0] < head.centre[0]:
            cost += SIDE_RULE
    return cost


def size_rule_cost(name: str, radius_m: float, clipped: bool = False,
                   sd_m: float = SIZE_SD_FLOOR_M) -> float:
    """Up to ``SIZE_RULE`` when a consistent pair's metric size (reading ``radius_m`` with
    standard deviation ``sd_m``) speaks against the name, graded by the head / hand likelihood
    ratio (:func:`~humimic.perception.blobs.sizes.size_cost`; NaN: no evidence). A ``clipped``
    pair's size is a lower bound: it cannot show a head too small."""
    if name != "head" and name not in HANDS:
        return 0.0
    return size_cost(name == "head", radius_m, sd_m, clipped, SIZE_RULE)


def stereo_evidence(rig: StereoRig, cam_left, cam_right, left: list[Blob], right: list[Blob],
                    gate: float = 2.0, z_range=(0.1, 20.0)) -> PairEvidence:
    """Triangulate every pair of centres (DLT), reproject into both eyes and judge it.

    A pair is inconsistent when a reprojection is further than ``gate`` from its blob centre in
    the blob's Mahalanobis metric, or the point's depth in either eye is outside ``z_range``
    (m). A consistent pair's metric sigma radius is ``det(Sigma)^(1/4) z / f``, averaged over
    the eyes.
    """
    incons = np.ones((len(left), len(right)), bool)
    radius = np.full((len(left), len(right)), np.nan)
    sd = np.full((len(left), len(right)), np.nan)
    clipped = np.array([[a.clipped or b.clipped for b in right] for a in left],
                       bool).reshape(len(left), len(right))
    if not left or not right:
        return PairEvidence(incons, radius, clipped, sd)
    pairs = list(itertools.product(range(len(left)), range(len(right))))
    uvl = np.array([left[i].centre for i, _ in pairs], float)
    uvr = np.array([right[j].centre for _, j in pairs], float)
    p, _ = rig.triangulate(uvl, uvr)
    for (i, j), p_base, a, b in zip(pairs, p, uvl, uvr, strict=True):
        if not np.all(np.isfinite(p_base)):
            continue
        sizes, sds = [], []
        for cam, uv, blob in ((cam_left, a, left[i]), (cam_right, b, right[j])):
            T = np.linalg.inv(cam.T_base_cam)
            z = T[2, :3] @ p_base + T[2, 3]
            e = cam.project_base(p_base) - uv
            if not (z_range[0] <= z <= z_range[1] and e @ np.linalg.solve(blob.cov, e)
                    <= gate * gate):
                break
            sizes.append(math.sqrt(blob.area) * z / cam.intrinsics.fx)
            sds.append(radius_sd_m(z, cam.intrinsics.fx))
        else:
            incons[i, j] = False
            radius[i, j] = 0.5 * (sizes[0] + sizes[1])
            sd[i, j] = 0.5 * (sds[0] + sds[1])
    return PairEvidence(incons, radius, clipped, sd)


def clipped_by_border(centre: np.ndarray, cov: np.ndarray, width: int, height: int,
                      n_sigma: float = 2.0) -> bool:
    """Whether the blob's ``n_sigma`` ellipse (its axis-aligned extent) leaves the image."""
    half = n_sigma * np.sqrt(np.maximum(np.diag(np.asarray(cov, float)), 0.0))
    c = np.asarray(centre, float)
    return bool(c[0] - half[0] < 0 or c[1] - half[1] < 0 or c[0] + half[0] > width - 1
                or c[1] + half[1] > height - 1)


def _maps(blobs: list[Blob], targets: list[str]):
    """Every injective assignment of ``blobs`` to ``targets``: tuples of target names."""
    if len(blobs) > len(targets):
        raise ValueError(f"{len(blobs)} blobs for {len(targets)} targets")
    return itertools.permutations(targets, len(blobs))


def _holding_locks(blobs: list[Blob], targets: list[str],
                   locked: dict[int, str] | None) -> dict[int, str]:
    """The locks on ``blobs`` that can all hold: each names one of ``targets`` no other lock on
    ``blobs`` names (two slots locked to one name: neither binds; the others still do)."""
    mine = [(b.slot, locked[b.slot]) for b in blobs if locked and locked.get(b.slot) in targets]
    names = [n for _, n in mine]
    return {k: n for k, n in mine if names.count(n) == 1}


def _keeps_locks(blobs: list[Blob], names: tuple[str, ...], locked: dict[int, str]) -> bool:
    """Whether naming ``blobs`` ``names`` keeps every lock on them."""
    return all(locked.get(b.slot, n) == n for b, n in zip(blobs, names, strict=True))


def assign(targets: list[str], left: list[Blob], right: list[Blob],
           previous_left: dict[int, str], previous_right: dict[int, str],
           evidence: PairEvidence | None = None, keep: float = KEEP,
           locked_left: dict[int, str] | None = None, locked_right: dict[int, str] | None = None,
           away: bool = False
           ) -> tuple[dict[int, str], dict[int, str], dict[str, float]]:
    """The cheapest joint identity assignment and per-target margins.

    Returns ``({slot: target} left, {slot: target} right, {target: margin})``. ``targets`` are
    the same-coloured targets the blobs can be; ``previous_*`` the current identities;
    ``evidence`` from :func:`stereo_evidence` (None: no stereo terms). Ties go to the first
    candidate in ``targets`` order. A target's margin is how much more *evidence* cost (rules
    and stereo, without the continuity bonus) the cheapest assignment that gives it other
    blobs has (inf if none exists): continuity chooses between equals, but never vouches.
    ``locked_*`` (``{slot: target}``): names the chosen assignment must keep (see the module
    docstring); a lock on a slot not among the blobs is ignored, and so is one naming a target
    not in ``targets`` or one another lock in that eye names too (:func:`_holding_locks`; the
    others hold); margins still weigh every assignment. ``away``: the image rules of a person
    with the back to the robot.
    """
    locked_left = _holding_locks(left, targets, locked_left)
    locked_right = _holding_locks(right, targets, locked_right)
    options: list[tuple[float, float, tuple[str, ...], tuple[str, ...]]] = []
    allowed: list[bool] = []
    sized: dict[tuple[str, int, int], float] = {}   # size rule costs, each computed once
    for names_l in _maps(left, targets):
        free_l = _keeps_locks(left, names_l, locked_left)
        cost_l = image_rule_cost(dict(zip(names_l, left, strict=True)), away)
        kept_l = keep * sum(previous_left.get(b.slot) == n
                            for b, n in zip(left, names_l, strict=True))
        where_l = {n: i for i, n in enumerate(names_l)}
        for names_r in _maps(right, targets):
            cost = cost_l + image_rule_cost(dict(zip(names_r, right, strict=True)), away)
            kept = kept_l + keep * sum(previous_right.get(b.slot) == n
                                       for b, n in zip(right, names_r, strict=True))
            if evidence is not None:
                for j, name in enumerate(names_r):
                    i = where_l.get(name)
                    if i is None:
                        continue
                    if evidence.inconsistent[i, j]:
                        cost += STEREO_RULE
                    else:
                        key = (name, i, j)
                        if key not in sized:
                            sized[key] = size_rule_cost(
                                name, float(evidence.radius_m[i, j]),
                                evidence.clipped is not None and bool(evidence.clipped[i, j]),
                                SIZE_SD_FLOOR_M if evidence.radius_sd_m is None
                                else float(evidence.radius_sd_m[i, j]))
                        cost += sized[key]
                        cost -= PAIR_BONUS
            options.append((cost - kept, cost, names_l, names_r))
            allowed.append(free_l and _keeps_locks(right, names_r, locked_right))
    best = min((k for k in range(len(options)) if allowed[k]), key=lambda k: (options[k][0], k))
    _, evidence0, best_l, best_r = options[best]
    bound = best != min(range(len(options)), key=lambda k: (options[k][0], k))

    def slots(names_l, names_r, target):
        sl = next((b.slot for b, n in zip(left, names_l, strict=True) if n == target), None)
        sr = next((b.slot for b, n in zip(right, names_r, strict=True) if n == target), None)
        return sl, sr

    margins = {}
    for target in targets:
        mine = slots(best_l, best_r, target)
        alt = [c for _, c, nl, nr in options if slots(nl, nr, target) != mine]
        # a lock that overruled the rules weighs against the locked names only: the others
        # are judged on the cheapest assignment that names them alike
        ref = min(c for _, c, nl, nr in options if slots(nl, nr, target) == mine) if bound \
            else evidence0
        margins[target] = (min(alt) - ref) if alt else math.inf
    return ({b.slot: n for b, n in zip(left, best_l, strict=True)},
            {b.slot: n for b, n in zip(right, best_r, strict=True)}, margins)


def fixed_names(locked, names, blobs, evidence: PairEvidence, n_targets: int
                ) -> list[dict[int, str]]:
    """Per eye, the names the locks fix (``locked``, ``names`` and ``blobs``: (left, right)
    ``{slot: target}``, ``{slot: target}`` of :func:`assign` and blob lists): the locked ones,
    the head's (the image rules name it by size whatever the facing), the name of a fixed
    blob's only stereo-consistent partner in the other eye (one object), and the last blob's
    when every other one is fixed and the eye sees as many blobs as there are targets."""
    fixed = [{**lk, **{k: x for k, x in nm.items() if x == "head"}}
             for lk, nm in zip(locked, names, strict=True)]
    ok = ~evidence.inconsistent
    for i, j in zip(*np.nonzero(ok), strict=True):
        if ok[i].sum() == 1 and ok[:, j].sum() == 1:  # each the other's only partner
            a, b = blobs[0][i].slot, blobs[1][j].slot
            x = fixed[0].get(a, fixed[1].get(b))
            if x is not None and names[0].get(a) == x == names[1].get(b):
                fixed[0][a] = fixed[1][b] = x
    for fx, nm in zip(fixed, names, strict=True):
        rest = [k for k in nm if k not in fx]
        if len(nm) == n_targets and len(rest) == 1:
            fx[rest[0]] = nm[rest[0]]
    return fixed


def stayed_on_own_blob(prev: np.ndarray, new: np.ndarray, others_prev: list[np.ndarray],
                       ratio: float = OWN_BLOB_RATIO) -> bool:
    """Whether a blob whose region of interest touched other same-coloured blobs' is still on
    its own object: from its centre ``prev`` (px) on the last frame to ``new`` on this one it
    moved at most ``ratio`` times the distance from ``new`` to the nearest of the other blobs'
    last centres ``others_prev``: nearest-neighbour association (Bar-Shalom & Fortmann 1988,
    *Tracking and Data Association*), accepted only when decided by a wide margin. EM handing
    the blob to the other object moves it onto the other's place, and blobs merging (centres
    within a few steps of each other) are not judged their own. No other blob: True."""
    d_self = float(np.hypot(*(np.asarray(new, float) - np.asarray(prev, float))))
    d_other = min((float(np.hypot(*(np.asarray(new, float) - np.asarray(o, float))))
                   for o in others_prev), default=math.inf)
    return d_self <= ratio * d_other


def turned_round(left: list[Blob], right: list[Blob], names_left: dict[int, str],
                 names_right: dict[int, str], away: bool) -> bool:
    """Whether names kept by locks show the person turned round: the image rules of the
    current facing (``away``) count at least :data:`TURN_RULES` violations over both eyes and
    those of the other facing none (a mirrored picture of head and hands; one hand crossing
    over leaves the other on its side and breaks a rule either way). The caller passes names it
    is sure of, head and both hands in both eyes: without the head, one hand crossing over the
    other at another height breaks the order rule alone, once per eye."""
    def cost(facing: bool) -> float:
        return sum(image_rule_cost({names[b.slot]: b for b in blobs if b.slot in names}, facing)
                   for blobs, names in ((left, names_left), (right, names_right)))

    return cost(away) >= TURN_RULES and cost(not away) == 0.0
