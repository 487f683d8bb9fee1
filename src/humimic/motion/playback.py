"""BVH playback: a retargeted clip as a :class:`~humimic.motion.context.HumanMotion`.

Motion time ``t`` shows clip time ``start + speed * t``; between frames slides and hinges are
interpolated linearly and ball joints by normalised linear interpolation of hemisphere-aligned
quaternions (the trajectory spline is then fitted at the clip's own frame rate over speed, so
with ``speed = 1`` and ``start`` on a frame it passes through the recorded frames). Past the
clip's end (or ``start + speed * duration``) the last pose is held.
"""

from __future__ import annotations

import numpy as np

from humimic.errors import InputError
from humimic.motion import quat
from humimic.motion.avatar import BALL_JOINTS, QPOS_SLICES, AvatarGeometry, range_violations
from humimic.motion.bvh import drop_first_frames, has_reference_frame, load_bvh
from humimic.motion.config import BVHMotion
from humimic.motion.context import MotionContext
from humimic.motion.retarget import Retargeted, retarget


class BVHPlayback:
    """A retargeted BVH clip played from ``start`` at ``speed``."""

    def __init__(self, clip: Retargeted, g: AvatarGeometry, start: float = 0.0,
                 speed: float = 1.0, duration: float | None = None):
        if len(clip.qpos) < 2:  # a single frame: hold it
            clip = Retargeted(np.repeat(clip.qpos, 2, axis=0), clip.frame_time, clip.scale,
                              clip.R_yaw, clip.offset)
        self.clip = clip
        self.geometry = g
        self.start = start
        self.speed = speed
        n = len(clip.qpos)
        clip_end = (n - 1) * clip.frame_time
        if start > clip_end:
            raise ValueError(f"start {start} s is after the clip's end ({clip_end:.3f} s)")
        self.end = clip_end if duration is None else min(clip_end, start + speed * duration)
        self.sample_rate = speed / clip.frame_time
        """Hz of motion time: one sample per clip frame."""

    @property
    def duration(self) -> float:
        """Motion seconds until the clip (or the requested duration) ends."""
        return (self.end - self.start) / self.speed

    def sample(self, t: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, float))
        tau = np.clip(self.start + self.speed * t, 0.0, self.end)
        x = tau / self.clip.frame_time
        i = np.clip(np.floor(x).astype(int), 0, len(self.clip.qpos) - 2)
        a = (x - i)[:, None]
        q0, q1 = self.clip.qpos[i], self.clip.qpos[i + 1]
        q = (1 - a) * q0 + a * q1
        for j in BALL_JOINTS:
            s = QPOS_SLICES[j]
            q[:, s] = quat.normalize(q[:, s])
        return q

    def diagnostics(self, t: np.ndarray) -> dict[str, float]:
        v = range_violations(self.sample(t), self.geometry)
        return {f"range_{j}_rad": x for j, x in v.items() if x > 0}


def make_bvh(c: BVHMotion, ctx: MotionContext) -> BVHPlayback:
    bvh = load_bvh(c.file)
    if c.skip_reference and has_reference_frame(bvh):
        bvh = drop_first_frames(bvh, 1)
    clip_end = (bvh.n_frames - 1) * bvh.frame_time
    if c.start > clip_end:
        raise InputError(f"{c.file}: start {c.start} s is after the clip's end "
                         f"({clip_end:.3f} s)")
    start_frame = min(int(round(c.start / bvh.frame_time)), bvh.n_frames - 1)
    clip = retarget(bvh, ctx.geometry, c.joint_map, c.scale, c.face_robot, start_frame,
                    c.smoothing)
    return BVHPlayback(clip, ctx.geometry, c.start, c.speed, c.duration)
