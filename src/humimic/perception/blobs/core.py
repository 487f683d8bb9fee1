"""The perception stage's per-frame work and state: both eye images -> named 3-D measurements.

:class:`PerceptionCore` owns everything that changes from frame to frame (both eyes' trackers
with their random generators, the blob identities and margins, the target states) and nothing
else: no bus, no recorder, no rerun. One call of :meth:`PerceptionCore.process` per stereo frame
returns a :class:`FrameResult` (the measurements and what the stage records and logs), so the
same object runs in the simulation's thread, in a worker thread or, pickled, in a worker process
(:mod:`humimic.perception.blobs.worker`) with identical results.

Per stereo frame (photon time ``t``):

1. each eye's :class:`~humimic.perception.blobs.detection.DetectingTracker` runs EM on its tracked
   blobs (Ude eqs. 1-7) and searches for the others (eqs. 8-9);
2. when the set of tracked blobs changed (or a name is still unsure, :meth:`PerceptionCore.
   _unsure`), blob identities are re-decided for both eyes jointly
   (:mod:`humimic.perception.blobs.identity`); otherwise every blob keeps its name;
3. every published target with a blob in both eyes is matched by ZNCC along the epipolar line
   and triangulated (eq. 10) with the cameras' poses *at the photon time* (from the eyes'
   current kinematics), so the measurement is in the base frame however head and eyes moved,
   and its covariance R is the configured pixel noise propagated through triangulation.

A target's state is ``tracking`` while it has a blob in both eyes and its identity is sure
(``identity_margin``), ``lost`` after that ended, ``searching`` before it ever started; every
change is reported as an event. Only tracked targets are measured.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from humimic.messages import Measurement, Measurements
from humimic.perception.blobs.detection import DetectingTracker, DetectionParams, TargetState
from humimic.perception.blobs.em_blobs import EMParams, rois_overlap
from humimic.perception.blobs.identity import (
    HANDS,
    Blob,
    assign,
    clipped_by_border,
    fixed_names,
    stayed_on_own_blob,
    stereo_evidence,
    turned_round,
)
from humimic.perception.blobs.occlusion import VisibleMass
from humimic.perception.blobs.record import STATE_CODE
from humimic.perception.blobs.stereo import StereoParams, StereoRig, small_blob_scale
from humimic.perception.blobs.triangulation import match_noise_px
from humimic.perception.cues.color_models import load_posterior_kernels
from humimic.scenario.base import pass_through

#: Identities are re-decided, and a target may be measured, once its blobs have been tracked
#: this many frames (a new blob starts from a random hypothesis; its centre and shape, which the
#: identity rules use, settle in a few frames).
SETTLE_FRAMES = 6
#: A name left unsure is re-decided this many frames after the last decision, and so on while
#: it stays unsure (:meth:`PerceptionCore._unsure`). Measured (thread CPU time, the scripted
#: core of tests/test_perception_locks.py, head and one hand per eye, 300 frames): 1.05 ms a
#: frame with sure names; re-deciding every frame 3.78 ms, every 6th 1.41 ms. ude_wave_tracking
#: at 2.2 m, seed 101, head only: head measured on 20 % of its visible frames without the
#: re-decision, 63 % re-deciding every frame, 58 % every 6th; the default runs unchanged.
RECHECK_FRAMES = 6


def detection_params(cfg) -> DetectionParams:
    """The ``perception.detection`` section, every key passed through under its own name."""
    return pass_through(DetectionParams, cfg.detection)


def em_params(cfg) -> EMParams:
    """The ``perception`` section's EM keys (``roi_side``, ``roi_k_sigma``, ``em_*``)."""
    return pass_through(EMParams, cfg)


def stereo_params(cfg) -> StereoParams:
    """The ``perception.stereo`` section (``color_mask`` is the core's: which images to match)."""
    return pass_through(StereoParams, cfg.stereo)


@dataclass(frozen=True)
class FrameResult:
    """What one stereo frame produced."""

    measurements: Measurements
    record_row: tuple
    """Arguments of :meth:`~humimic.perception.blobs.record.PerceptionRecord.append`."""
    intrinsics: tuple
    """(left, right) :class:`~humimic.sensors.camera_model.Intrinsics` of the frame."""
    events: list[tuple[float, str, str, str]]
    """Target state changes: ``(t, target, "old -> new", level)``."""
    viz: tuple
    """``(t, seen, centre, cov)`` for the blob ellipses in rerun."""
    identity_solves: int
    """Identity decisions so far (running count)."""
    facing_turns: int = 0
    """Times the person was judged to have turned round so far (running count)."""


class PerceptionCore:
    """See the module docstring. ``luts`` maps every tracked target (published targets first,
    then distractors) to its :class:`~humimic.perception.cues.color_models.ColorLUT`; targets
    sharing one LUT object are told apart by :mod:`~humimic.perception.blobs.identity`."""

    def __init__(self, cfg, cameras: tuple[str, str], luts: dict, rng: np.random.Generator):
        self.cameras = tuple(cameras)
        self.published = list(cfg.targets)
        self.targets = list(luts)
        if self.targets[:len(self.published)] != self.published:
            raise ValueError("luts must list the published targets first")
        lut_list = [luts[t] for t in self.targets]
        self.luts = lut_list
        self.groups: list[list[int]] = []  # slots sharing a colour model
        for k, lut in enumerate(lut_list):
            for g in self.groups:
                if lut_list[g[0]] is lut:
                    g.append(k)
                    break
            else:
                self.groups.append([k])
        self.em = em_params(cfg)
        self.trackers = [DetectingTracker(self.targets, lut_list, r, detection_params(cfg),
                                          self.em) for r in rng.spawn(2)]
        self.stereo = stereo_params(cfg)
        self.identity_margin = cfg.identity_margin
        self.lock_names = cfg.lock_names
        self.track_facing = cfg.lock_names and cfg.track_facing
        self.away = False
        """The person is judged to have the back to the robot (mirrored image rules)."""
        self.facing_turns = 0
        self._turn_events: list[tuple[float, str, str, str]] = []
        self.locked: list[dict[int, tuple[str, int]]] = [{}, {}]
        """Per eye, slot -> (name, age when last sure): names EM cannot have swapped since."""
        self.held: list[dict[int, tuple[str, int]]] = [{}, {}]
        """Per eye, the locks of blobs whose regions touch another same-coloured blob's, held
        aside: given back once apart if every frame kept the blob on its own object
        (:func:`~humimic.perception.blobs.identity.stayed_on_own_blob`), else dropped."""
        self._last: list[dict[int, np.ndarray]] = [{}, {}]
        """Per eye, the tracked slots' blob centres on the last frame."""
        self._group_of = {k: g for g in self.groups for k in g}
        self.color_mask = cfg.stereo.color_mask
        st = self.stereo
        self.visible = None if not st.occlusion_check else VisibleMass(
            st.occlusion_window_s, st.occlusion_min_drop, st.occlusion_spread_k,
            st.occlusion_min_asymmetry)
        """Each target's recent visible mass in both eyes (matches refused while it shrinks)."""
        if self.color_mask:   # the colour-masked crops' kernel, before the first match
            load_posterior_kernels()
        self.match_std = cfg.match_std if cfg.covariance == "following" else None
        self.C_px = np.eye(2) * cfg.pixel_std**2
        self.noise_ref_sigma = cfg.noise_ref_sigma_px
        self.match_floor = cfg.match_floor_px
        self.ident: list[dict[int, str]] = [{}, {}]
        self.margin: dict[str, float] = dict.fromkeys(self.targets, 0.0)
        """Identity margin of each target at the last decision (see identity.assign)."""
        self._tracked: list[frozenset] = [frozenset(), frozenset()]
        self._touch: list[set[int]] = [set(), set()]
        """Per eye, the slots whose regions touched a same-coloured blob's last frame."""
        self.state = dict.fromkeys(self.targets, "searching")
        self.identity_solves = 0
        self._since_identify = 0
        """Frames since the last identity decision."""

    def process(self, t: float, images: dict) -> FrameResult:
        """Track, identify, match and triangulate one stereo frame (``{camera: CameraImage}``)."""
        il, ir = images[self.cameras[0]], images[self.cameras[1]]
        reports = [self.trackers[0].process(t, il.image), self.trackers[1].process(t, ir.image)]
        tracked = [{k: Blob(k, r.centre, r.cov, clipped_by_border(r.centre, r.cov, w, h))
                    for k, r in enumerate(reps) if r.state == TargetState.TRACKING}
                   for reps, (h, w) in zip(reports, (il.image.shape[:2], ir.image.shape[:2]),
                                           strict=True)]
        rig = StereoRig(il.camera, ir.camera, self.stereo)
        keys = [frozenset(tr) for tr in tracked]
        touching = self._touching(tracked)
        self._release_locks(t, tracked, touching)
        settled = any(int(t.tracker.age[k]) == SETTLE_FRAMES
                      for t, tr in zip(self.trackers, tracked, strict=True) for k in tr)
        # blobs apart again after their regions touched may have been swapped by EM: re-decide
        parted = any(self._touch[e] - touching[e] for e in (0, 1))
        self._touch = touching
        self._since_identify += 1
        if (keys != self._tracked or settled or parted
                or (self._since_identify >= RECHECK_FRAMES and self._unsure(tracked))):
            self._identify(t, tracked, rig, il.camera, ir.camera)
            self._tracked = keys
        slot_of = [{name: k for k, name in ident.items()} for ident in self.ident]

        n = len(self.targets)
        seen = np.zeros((n, 2), bool)
        centre, cov = np.zeros((n, 2, 2)), np.zeros((n, 2, 2, 2))
        for i, name in enumerate(self.targets):
            for eye in (0, 1):
                k = slot_of[eye].get(name)
                if k is not None:
                    seen[i, eye] = True
                    centre[i, eye], cov[i, eye] = tracked[eye][k].centre, tracked[eye][k].cov
        ok = np.zeros(n, bool)
        reason = ["not_seen"] * n
        # sure of the name, and both blobs past their start-up (a new blob begins as a random
        # hypothesis; its first frames' centres and shapes are still converging)
        age = [t.tracker.age for t in self.trackers]
        confirmed = np.array([
            self.margin[x] >= self.identity_margin
            and all(x in slot_of[e] and age[e][slot_of[e][x]] >= SETTLE_FRAMES for e in (0, 1))
            for x in self.targets])
        pub = []
        for i in range(len(self.published)):
            if seen[i].all():
                if confirmed[i]:
                    pub.append(i)
                else:
                    reason[i] = "identity_unsure"
        p_base, R_base = np.zeros((n, 3)), np.zeros((n, 3, 3))
        uv_match, score = np.zeros((n, 2, 2)), np.zeros(n)
        measured: dict[str, Measurement] = {}
        if pub:  # the calibrated pixel noises, grown for blobs smaller than calibrated on
            k = small_blob_scale(cov[pub, 0], self.noise_ref_sigma)
            C_px = self.C_px * np.square(k)[:, None, None]
            ms = rig.match_many(il.image, ir.image, centre[pub, 0], cov[pub, 0], centre[pub, 1],
                                cov[pub, 1], C_px, C_px,
                                [self.luts[i] for i in pub] if self.color_mask else None,
                                None if self.match_std is None
                                else match_noise_px(self.match_std, k, self.match_floor))
            for i, m in zip(pub, ms, strict=True):
                reason[i], score[i] = m.reason, m.score
                if (m.ok and self.color_mask and self.visible is not None
                        and self.visible.hidden(self.targets[i], t, m.mass_px)):
                    reason[i] = "shrinking_blob"  # being hidden: the match follows the edge
                elif m.ok:
                    ok[i], p_base[i], R_base[i] = True, m.p_base, m.R_base
                    uv_match[i] = m.uv_left, m.uv_right
                    name = self.targets[i]
                    measured[name] = Measurement(name, m.p_base, m.R_base,
                                                 {self.cameras[0]: m.uv_left,
                                                  self.cameras[1]: m.uv_right})
        if self.lock_names:  # sure names of blobs EM cannot swap now (regions apart)
            for i in np.flatnonzero(seen.all(1) & confirmed).tolist():
                x = self.targets[i]
                for eye, lock in enumerate(self.locked):
                    k = slot_of[eye][x]
                    if k not in touching[eye]:
                        for held in (lock, self.held[eye]):
                            for j in [j for j, v in held.items() if v[0] == x]:
                                del held[j]
                        lock[k] = (x, int(age[eye][k]))
        events = self._turn_events + self._update_states(t, seen.all(1) & confirmed)
        self._turn_events = []
        row = (t, np.stack([il.camera.T_base_cam, ir.camera.T_base_cam]),
               np.array([STATE_CODE[self.state[x]] for x in self.targets]), seen, confirmed,
               centre, cov, ok, reason, p_base, R_base, uv_match, score)
        return FrameResult(Measurements(measured, {x: self.state[x] for x in self.published}),
                           row, (il.camera.intrinsics, ir.camera.intrinsics), events,
                           (t, seen, centre, cov), self.identity_solves, self.facing_turns)

    def _identify(self, t: float, tracked, rig, cam_l, cam_r) -> None:
        """Re-decide the identities of every colour group's tracked blobs (both eyes); locked
        names that show the person turned round flip the image rules' facing
        (:func:`~humimic.perception.blobs.identity.turned_round`)."""
        self.identity_solves += 1
        self._since_identify = 0
        new: list[dict[int, str]] = [{}, {}]
        for group in self.groups:
            names = [self.targets[k] for k in group]
            blobs = [[tr[k] for k in group if k in tr] for tr in tracked]
            if len(group) == 1:  # a colour of its own: the slot is the target
                for eye in (0, 1):
                    if blobs[eye]:
                        new[eye][group[0]] = names[0]
                self.margin[names[0]] = np.inf
                continue
            ev = stereo_evidence(rig, cam_l, cam_r, blobs[0], blobs[1],
                                 z_range=(self.stereo.z_min, self.stereo.z_max))
            prev = [{k: v for k, v in self.ident[eye].items() if k in group} for eye in (0, 1)]
            locks = [{k: v[0] for k, v in self.locked[eye].items() if k in group}
                     for eye in (0, 1)]
            args = (names, blobs[0], blobs[1], prev[0], prev[1], ev)
            kw = {"locked_left": locks[0], "locked_right": locks[1]}
            left, right, margins = assign(*args, **kw, away=self.away)
            # a turn is judged on the names the locks fix (identity.fixed_names), the head's
            # among them in both eyes: without the head a hand crossing over the other at
            # another height breaks the order rule alone
            sure = fixed_names(locks, (left, right), blobs, ev, len(names))
            if (self.track_facing and any(n in HANDS for lk in locks for n in lk.values())
                    and all("head" in sn.values() for sn in sure)
                    and turned_round(blobs[0], blobs[1], sure[0], sure[1], self.away)):
                old = "away" if self.away else "toward"
                self.away = not self.away
                self.facing_turns += 1
                self._turn_events.append(
                    (t, "person", f"facing {old} -> {'away' if self.away else 'toward'}",
                     "INFO"))
                left, right, margins = assign(*args, **kw, away=self.away)
            new[0].update(left)
            new[1].update(right)
            self.margin.update(margins)
        self.ident = new

    def _unsure(self, tracked) -> bool:
        """Whether a target named in both eyes, on settled blobs, was left unsure by the last
        decision (margin below ``identity_margin``): its evidence (the blobs' positions and
        metric sizes) is measured afresh every frame, so it is re-decided (every
        :data:`RECHECK_FRAMES`) until sure. Decided
        only when the set of blobs changed, a margin that one noisy size reading left at 0
        stayed there: a head 2.2 m away (its sigma radius read 0.041-0.044 m against the
        hands' hard limit of 0.042 the size rule had before it was graded) named but never
        measured while nothing else changed."""
        for name in set(self.ident[0].values()) & set(self.ident[1].values()):
            if self.margin[name] >= self.identity_margin:
                continue
            slots = [next(k for k, x in self.ident[e].items() if x == name) for e in (0, 1)]
            if all(k in tracked[e] and self.trackers[e].tracker.age[k] >= SETTLE_FRAMES
                   for e, k in enumerate(slots)):
                return True
        return False

    def _touching(self, tracked) -> list[set[int]]:
        """Per eye, the tracked slots whose region of interest (after EM) overlaps another
        tracked blob's of their colour group: EM may swap them."""
        out: list[set[int]] = [set(), set()]
        for eye, tr in enumerate(tracked):
            for group in self.groups:
                for a, b in itertools.combinations([k for k in group if k in tr], 2):
                    if rois_overlap(tr[a].centre, tr[a].cov, tr[b].centre, tr[b].cov, self.em):
                        out[eye] |= {a, b}
        return out

    def _release_locks(self, t: float, tracked, touching) -> None:
        """Drop the locks of blobs no longer tracked without a break (lost, or restarted: younger
        than when locked); hold aside (:attr:`held`) those of blobs ``touching`` another of their
        colour (:meth:`_touching`: EM may swap them), drop a held lock once its blob's step
        does not show it on its own object
        (:func:`~humimic.perception.blobs.identity.stayed_on_own_blob`, against the other
        same-coloured blobs' last centres), and give it back once the blob touches none. A
        person judged turned round faces the robot again (the default) once the person (head
        and hands) is lost in both eyes."""
        for eye, tr in enumerate(tracked):
            age = self.trackers[eye].tracker.age
            lock, held, last = self.locked[eye], self.held[eye], self._last[eye]
            for k in list(lock):
                if k not in tr or int(age[k]) < lock[k][1]:
                    del lock[k]
                elif k in touching[eye]:
                    held[k] = lock.pop(k)
            for k in list(held):
                others = [last[j] for j in self._group_of[k] if j != k and j in last]
                if (k not in tr or int(age[k]) < held[k][1] or k not in last
                        or not stayed_on_own_blob(last[k], tr[k].centre, others)):
                    del held[k]
                elif k not in touching[eye]:
                    name = held.pop(k)
                    if all(v[0] != name[0] for v in lock.values()):
                        lock[k] = name
            self._last[eye] = {k: b.centre for k, b in tr.items()}
        skin = [k for k, x in enumerate(self.targets) if x in ("head", *HANDS)]
        if self.away and not any(k in tr for tr in tracked for k in skin):
            self.away = False
            self._turn_events.append((t, "person", "facing away -> toward (person lost)", "INFO"))

    def _update_states(self, t: float, tracking: np.ndarray) -> list[tuple]:
        events = []
        for i, name in enumerate(self.targets):
            old = self.state[name]
            new = "tracking" if tracking[i] else ("searching" if old == "searching" else "lost")
            if new != old:
                self.state[name] = new
                events.append((t, name, f"{old} -> {new}",
                               "INFO" if new == "tracking" else "WARN"))
        return events
