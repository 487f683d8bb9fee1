"""A person's shoulder range of motion beyond the joint-angle box: the humeral twist.

The box of :class:`~humimic.bodymodel.limits.JointLimits` bounds DB's Euler angles (SFE, SAA,
HR), whose HR is the humerus' rotation only near the rest pose: at SAA = 90 deg SFE and HR turn
about the same axis, so the box cannot say how far the upper arm is turned about its own axis.
:func:`humeral_twist` measures that turn by the swing-twist decomposition of the shoulder's
rotation: ``R_torso_upper = R_swing Rz(psi)``, ``R_swing`` the smallest rotation taking the
hanging arm's axis (-z) onto the upper arm's, ``psi`` the twist about the arm's own axis (0: the
elbow bends forwards as at rest with HR = 0; + internal, the forearm turned towards the body,
- external). It is the clinical internal / external rotation wherever the arm is raised in the
frontal or sagittal plane (the swing leaves the forward axis where the clinical measurement
puts it: at 90 deg abduction the forearm of a 90 deg external twist points up).

Published active ranges (:data:`TWIST_RANGE_DEG`): internal rotation 70 deg, external rotation
90 deg (American Academy of Orthopaedic Surgeons, "Joint Motion: Method of Measuring and
Recording", 1965; Norkin & White, "Measurement of Joint Motion", 5th ed. 2016, table of normal
shoulder ROM: flexion 0-180, extension 0-60, abduction 0-180, medial rotation 0-70, lateral
rotation 0-90 deg; young athletes reach 100-110 deg external at 90 deg abduction, Vairo et al.
2012, doi:10.1186/1758-2555-4-33). The other shoulder ranges of these sources (flexion 180,
extension 60, abduction 180, adduction 30 deg, elbow flexion 150 deg) are the box's defaults
(:data:`~humimic.bodymodel.limits.DEFAULT_LIMITS`).
"""

from __future__ import annotations

import numpy as np

from humimic.bodymodel.kinematics import ARM_AXES, shoulder_rotation

#: (external, internal) humeral twist a person reaches (deg, + internal): AAOS / Norkin & White.
TWIST_RANGE_DEG = (-90.0, 70.0)
#: Swing from hanging (rad) beyond which :func:`arm_twist_log_prior` fades out.
FADE_FROM = np.radians(135.0)


def _twist(side: str, R: np.ndarray) -> np.ndarray:
    """The twist angle (rad, + internal) of shoulder rotations ``R (..., 3, 3)``: ``2 atan2(q_z,
    q_w)`` of the swing-twist decomposition about the hanging axis."""
    return ARM_AXES[side][2][1] * np.arctan2(R[..., 1, 0] - R[..., 0, 1],
                                             R[..., 0, 0] + R[..., 1, 1])


def humeral_twist(side: str, sfe, saa, hr) -> np.ndarray:
    """``(...)`` the upper arm's twist about its own axis (rad, + internal; module doc) for DB's
    shoulder angles of arm ``side`` (rad). Undefined with the arm straight up (the swing's
    pole, 180 deg from hanging), and ever more sensitive near it: at 170 deg of elevation
    +-10 deg of abduction turn it by +-90 deg."""
    return _twist(side, shoulder_rotation(side, sfe, saa, hr))


def arm_twist_log_prior(side: str, sfe, saa, hr, lo: float, hi: float, sd: float
                        ) -> np.ndarray:
    """:func:`twist_log_prior` of arm ``side``'s :func:`humeral_twist`, in full up to
    :data:`FADE_FROM` of swing from hanging and faded to 0 straight up, where the twist is
    undefined: by ``((1 + cos swing) / (1 + cos FADE_FROM))^2``, which outpaces the twist's
    growing error there (a near-overhead arm is not penalised for a twist it hardly has)."""
    R = shoulder_rotation(side, sfe, saa, hr)
    fade = np.minimum((1.0 + R[..., 2, 2]) / (1.0 + np.cos(FADE_FROM)), 1.0) ** 2
    return fade * twist_log_prior(_twist(side, R), lo, hi, sd)


def twist_log_prior(twist: np.ndarray, lo: float, hi: float, sd: float) -> np.ndarray:
    """Log-prior (up to a constant) of twists ``twist`` (rad): flat within ``[lo, hi]``, a
    half-Gaussian fall-off of standard deviation ``sd`` beyond (a soft range of motion)."""
    excess = np.maximum(lo - twist, 0.0) + np.maximum(twist - hi, 0.0)
    return -0.5 * (excess / sd) ** 2
