"""The simulated person's motion: configs, primitives, BVH playback, IK, smooth trajectories and
ground truth at every physics step.

Typical use (the runner)::

    ctx = MotionContext.from_scene(scene, duration, rng)
    traj = JointTrajectory.from_motion(make_motion(cfg, ctx), duration)
    gt = compute_ground_truth(scene, traj, step_times)
    scene.data.qpos[scene.human_qpos] = gt.qpos[i]   # every physics step
"""

# humimic.scenario's package imports the scenario schema, which imports this package's config;
# importing it first lets either package be imported first without a circular-import error.
import humimic.scenario  # noqa: F401, I001
from humimic.motion.bvh import BVHError
from humimic.motion.config import MotionConfig
from humimic.motion.context import HumanMotion, MotionContext
from humimic.motion.factory import make_motion, make_trajectory
from humimic.motion.ground_truth import GroundTruth, compute_ground_truth
from humimic.motion.trajectory import JointTrajectory

__all__ = [
    "BVHError",
    "GroundTruth",
    "HumanMotion",
    "JointTrajectory",
    "MotionConfig",
    "MotionContext",
    "compute_ground_truth",
    "make_motion",
    "make_trajectory",
]
