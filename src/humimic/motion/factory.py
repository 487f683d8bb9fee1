"""Config -> motion."""

from __future__ import annotations

from humimic.motion.config import (
    AxesMotion,
    BVHMotion,
    Figure8Motion,
    HeadSweepMotion,
    JumpMotion,
    KeyframesMotion,
    MotionConfig,
    PointMotion,
    StaticMotion,
    WalkMotion,
    WaveMotion,
)
from humimic.motion.context import HumanMotion, MotionContext
from humimic.motion.keyframes import make_keyframes
from humimic.motion.locomotion import make_jump, make_walk
from humimic.motion.playback import make_bvh
from humimic.motion.primitives import (
    make_axes,
    make_figure8,
    make_head_sweep,
    make_point,
    make_static,
    make_wave,
)
from humimic.motion.trajectory import JointTrajectory

_MAKERS = {
    StaticMotion: make_static,
    WaveMotion: make_wave,
    AxesMotion: make_axes,
    PointMotion: make_point,
    HeadSweepMotion: make_head_sweep,
    Figure8Motion: make_figure8,
    KeyframesMotion: make_keyframes,
    BVHMotion: make_bvh,
    WalkMotion: make_walk,
    JumpMotion: make_jump,
}


def make_motion(cfg: MotionConfig, ctx: MotionContext) -> HumanMotion:
    """The motion described by ``cfg`` (avatar frame; randomness only from ``ctx.rng``)."""
    return _MAKERS[type(cfg)](cfg, ctx)


def make_trajectory(cfg: MotionConfig, ctx: MotionContext) -> JointTrajectory:
    """``make_motion`` fitted over ``[0, ctx.duration]`` at the motion's own sample rate."""
    return JointTrajectory.from_motion(make_motion(cfg, ctx), ctx.duration)
