"""Human-to-robot mapping by relative motion, its scale, and clamping into a site's reachable
shell.

Ude & Atkeson, "Generation of humanoid motion from human motion": "At the beginning of the
mimicking task we save the initial position of a tracked human body part and the initial
position of the corresponding robot body part [...] we move the robot hand in such a way that
the position of the robot hand with respect to the initial robot hand position is the same as
the position of the human hand with respect to the initial human hand position." Both are in
the robot base frame (the eyes are kept still, so the base frame stays aligned with the
cameras). Here with a scale ``s`` and a reflection ``M`` (identity for the paper's mode)::

    p_robot(t) = p_robot(t0) + s M (p_human(t) - p_human(t0))

``mirrored`` makes the robot the person's mirror image: the mirror plane lies between them,
perpendicular to the robot's x axis (forward), so depth is reversed and the lateral and
vertical motion kept (the person's right hand then naturally drives the robot's *left* hand).

The scale makes the person's motion fit the robot (the paper copies displacements 1:1; DB's
joint limits then bite, its Sec. 5). Two parts, both per driven site:

* the initial scale ``s0`` (``mimic.scale``): a number, or ``auto``: the robot arm's length over
  the person's (:func:`auto_scale`; shoulder to palm, or shoulder to elbow for an elbow site) -
  a short-armed person's wave becomes the robot's full wave;
* the fit (``mimic.fit``): a mapped displacement ``s M d`` from the anchor ``p_robot(t0)`` must
  end in the site's reachable shell (a margin inside it). When the person moves further, the
  largest scale below the current one that ends in the shell follows from where the ray from
  the anchor along ``M d`` leaves the outer sphere or enters the inner one
  (:func:`reach_along_ray`); the scale decays towards it with a time constant (a single wild
  estimate barely moves it; an arm raised for a second does) and never grows back: once the
  person has shown their range, the whole of it maps inside (:class:`ScaleFit`). The shell
  knows the arm's length but not its joint limits or its body, so the fit also listens to the
  IK: while the arm is strained (the IK misses the command, or a shoulder or elbow joint sits
  on its limit band, where DB "becomes more jerky", Ude & Atkeson Sec. 5) the scale shrinks at
  a fixed relative rate. Clamping then only acts while the scale is still shrinking, and the
  error is scored against the target at the scale in use.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

#: Reflection per mapping mode (robot base frame: x forward, y left, z up).
REFLECTIONS = {
    "relative": np.eye(3),
    "follow": np.eye(3),
    "mirrored": np.diag([-1.0, 1.0, 1.0]),
}

#: For each drivable site: (shoulder body, elbow joint) of its arm, in the robot model.
ARM_OF_SITE = {
    "R_palm": ("R_upper_arm", "R_EB"),
    "L_palm": ("L_upper_arm", "L_EB"),
    "R_elbow": ("R_upper_arm", "R_EB"),
    "L_elbow": ("L_upper_arm", "L_EB"),
}


def mapping_matrix(mode: str, scale: float) -> np.ndarray:
    """``S = s M``: the 3x3 map from a human displacement to a robot displacement."""
    return scale * REFLECTIONS[mode]


def map_displacement(p_base_human: np.ndarray, p0_base_human: np.ndarray,
                     p0_base_robot: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Commanded robot-site position for human position(s) ``(..., 3)`` (Ude, relative motion):
    ``p0_robot + S (p_human - p0_human)``."""
    return p0_base_robot + (np.asarray(p_base_human) - p0_base_human) @ S.T


def clamp_to_shell(p: np.ndarray, center: np.ndarray, r_min: float,
                   r_max: float) -> tuple[np.ndarray, bool]:
    """Move ``p`` radially (about ``center``) into the shell ``r_min <= |p - c| <= r_max``.

    Returns the clamped point and whether it moved. A point at the centre (direction undefined)
    goes straight down from it, where arms hang.
    """
    d = p - center
    r = float(np.sqrt(d @ d))
    if r_min <= r <= r_max:
        return p, False
    if r < 1e-12:
        return center + np.array([0.0, 0.0, -max(r_min, 0.0)]), True
    return center + d * (min(max(r, r_min), r_max) / r), True


def reach_along_ray(a: np.ndarray, u: np.ndarray, lam: float, center: np.ndarray,
                    r_min: float, r_max: float) -> float:
    """How far (at most ``lam``) one may go from ``a`` (in the shell ``r_min <= |p - c| <=
    r_max``) along the unit direction ``u`` and be in the shell: ``lam`` if ``a + lam u`` is in
    it; else, for a point beyond the outer sphere, where the ray leaves it; for a point inside
    the inner sphere, where the ray enters it (ray-sphere intersection ``|w + l u|^2 = r^2``,
    ``w = a - c``). A ray that crosses the inner sphere and comes out again keeps its end."""
    w = np.asarray(a, float) - center
    b, ww = float(u @ w), float(w @ w)
    r2 = ww + 2.0 * lam * b + lam * lam  # |a + lam u - c|^2
    if r2 > r_max * r_max:
        return float(min(lam, max(-b + np.sqrt(max(b * b - ww + r_max * r_max, 0.0)), 0.0)))
    if r2 < r_min * r_min:
        return float(min(lam, max(-b - np.sqrt(max(b * b - ww + r_min * r_min, 0.0)), 0.0)))
    return float(lam)


def arm_length(model: mujoco.MjModel, site: str) -> float:
    """Shoulder to ``site`` along the robot arm's links (m): upper arm plus, for a palm, the
    elbow-palm distance (rigid links, so any configuration gives the same)."""
    shoulder_body, elbow_joint = ARM_OF_SITE[site]
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    p_shoulder = d.body(shoulder_body).xpos
    p_elbow = d.xanchor[model.joint(elbow_joint).id]
    p_site = d.site(site).xpos
    if site.endswith("elbow"):
        return float(np.linalg.norm(p_site - p_shoulder))
    return float(np.linalg.norm(p_elbow - p_shoulder) + np.linalg.norm(p_site - p_elbow))


def auto_scale(robot_arm: float, human_upper_arm: float, human_lower_arm: float,
               site: str) -> float:
    """``mimic.scale: auto``: the robot site's arm length over the person's matching length
    (whole arm for a palm, upper arm for an elbow)."""
    human = human_upper_arm if site.endswith("elbow") else human_upper_arm + human_lower_arm
    return robot_arm / human


class ScaleFit:
    """The scale in use for one site (see the module docstring): starts at ``scale`` and decays
    towards the largest scale that keeps each mapped displacement inside the shell (about its
    shoulder) shrunk by ``margin``, with time constant ``time_constant`` (s), and by
    ``strain_rate`` (1/s, relative) while the arm is strained; never grows."""

    def __init__(self, scale: float, shell: ReachShell, anchor: np.ndarray, margin: float,
                 time_constant: float, dt: float, strain_rate: float = 0.0):
        self.scale = self.initial = float(scale)
        self.strain_gain = min(1.0, strain_rate * dt)
        self.strained_ticks = 0
        self.shell, self.anchor = shell, np.asarray(anchor, float)
        r_min, r_max = shell.r_min + margin, shell.r_max - margin
        r0 = float(np.linalg.norm(self.anchor - shell.center))
        # an anchor already inside the margin keeps its own radius as the bound
        self.r_min, self.r_max = min(r_min, r0), max(r_max, r0)
        self.gain = min(1.0, dt / time_constant) if time_constant > 0.0 else 1.0

    def bound(self, d: np.ndarray) -> float:
        """Largest scale up to the current one that puts ``anchor + s d`` in the shell (``d``
        the reflected displacement)."""
        n = float(np.linalg.norm(d))
        if n < 1e-9:
            return self.scale
        return reach_along_ray(self.anchor, d / n, self.scale * n, self.shell.center,
                               self.r_min, self.r_max) / n

    def update(self, d: np.ndarray) -> float:
        """The scale for the reflected human displacement ``d = M (p - p0)`` of this tick."""
        bound = self.bound(d)
        if bound < self.scale:
            self.scale += self.gain * (bound - self.scale)
        return self.scale

    def strain(self, strained: bool) -> None:
        """After the IK step: shrink the scale by ``strain_rate dt`` if the arm was strained."""
        if strained:
            self.strained_ticks += 1
            self.scale *= 1.0 - self.strain_gain


@dataclass(frozen=True)
class ReachShell:
    """Where a site can be: a spherical shell about its shoulder (robot base frame, m)."""

    center: np.ndarray
    r_min: float
    r_max: float

    def clamp(self, p: np.ndarray) -> tuple[np.ndarray, bool]:
        return clamp_to_shell(p, self.center, self.r_min, self.r_max)


def reach_shell(model: mujoco.MjModel, q: np.ndarray, site: str, T_world_base: np.ndarray,
                margin: float = 0.01) -> ReachShell:
    """The reachable shell of ``site`` about its shoulder, from the robot model's kinematics.

    The radius range is swept over the elbow joint's range with the other joints at ``q``
    (every other arm joint only rotates the arm about the shoulder, and the wrist joints barely
    move the palm centre). ``margin`` keeps the commands off the straight-arm singularity and the
    elbow stop; an elbow site has a single radius (its shell is a sphere). The torso is assumed
    at ``q`` (the head-still task keeps it nearly so).
    """
    shoulder_body, elbow_joint = ARM_OF_SITE[site]
    d = mujoco.MjData(model)
    jid = model.joint(elbow_joint).id
    adr = model.jnt_qposadr[jid]
    lo, hi = model.jnt_range[jid]
    radii = []
    for angle in np.linspace(lo, hi, 49):
        d.qpos[:] = q
        d.qpos[adr] = angle
        mujoco.mj_kinematics(model, d)
        radii.append(np.linalg.norm(d.site(site).xpos - d.body(shoulder_body).xpos))
    d.qpos[:] = q
    mujoco.mj_kinematics(model, d)
    R, t = T_world_base[:3, :3], T_world_base[:3, 3]
    center = R.T @ (d.body(shoulder_body).xpos - t)
    r_min, r_max = float(min(radii)), float(max(radii))
    m = min(margin, (r_max - r_min) / 4.0)
    # The start position is always allowed (a straight arm starts outside the margin).
    r0 = float(np.linalg.norm(d.site(site).xpos - d.body(shoulder_body).xpos))
    return ReachShell(center, min(r_min + m, r0), max(r_max - m, r0))
