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


def humeral_twist(side: str, sfe, saa, hr) -> np.ndarray:
    """``(...)`` the upper arm's twist about its own axis (rad, + internal; module doc) for DB's
    shoulder angles of arm ``side`` (rad)."""
    R = shoulder_rotation(side, sfe, saa, hr)
    psi = np.arctan2(R[..., 1, 0] - R[..., 0, 1], R[..., 0, 0] + R[..., 1, 1])
    return ARM_AXES[side][2][1] * psi


def twist_log_prior(twist: np.ndarray, lo: float, hi: float, sd: float) -> np.ndarray:
    """Log-prior (up to a constant) of twists ``twist`` (rad): flat within ``[lo, hi]``, a
    half-Gaussian fall-off of standard deviation ``sd`` beyond (a soft range of motion)."""
    excess = np.maximum(lo - twist, 0.0) + np.maximum(twist - hi, 0.0)
    return -0.5 * (excess / sd) ** 2
