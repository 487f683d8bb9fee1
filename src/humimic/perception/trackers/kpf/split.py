"""Our extension ``split_arms``: partitioned sampling (MacCormick & Isard 2000) with each arm split
into a shoulder group (SFE, SAA, HR) and an elbow group (EB), five groups in all: the torso, the
right shoulder, the right elbow, the left shoulder, the left elbow.

Each group is shifted, weighted and resampled with the likelihood terms of the limbs its DOFs
move (Schmidt eq. 10's factors, summed in log): the torso's with the whole pose's (as
``partitioned``), a shoulder's with its whole arm's (upper arm, forearm, hand), an elbow's with
its forearm's and hand's only (the upper arm does not move with the elbow). ``split_resample``:
``groups``, each of the five groups from its own ancestor; ``arm``, an arm's shoulder and elbow
from the same ancestor (drawn with the shoulder's weights, the whole arm's likelihood).
"""

from __future__ import annotations

import numpy as np

from humimic.estimation.particles import kernel as kpf

#: The shoulder's DOFs and the elbow's, per arm prefix of :data:`humimic.bodymodel.DOF_NAMES`.
SHOULDER_DOFS = ("SFE", "SAA", "HR")
ELBOW_DOFS = ("EB",)
#: Arm prefixes in the DOF names and the body's part names.
ARM_SIDES = (("R_", "r_"), ("L_", "l_"))


def split_groups(dof_names: tuple[str, ...] | list[str]) -> list[np.ndarray]:
    """The five groups' DOF indices: torso (every DOF not an arm's), R shoulder, R elbow,
    L shoulder, L elbow."""
    names = list(dof_names)
    arm = {f"{s}{d}" for s, _ in ARM_SIDES for d in SHOULDER_DOFS + ELBOW_DOFS}
    groups = [np.array([i for i, n in enumerate(names) if n not in arm])]
    for s, _ in ARM_SIDES:
        for dofs in (SHOULDER_DOFS, ELBOW_DOFS):
            groups.append(np.array([names.index(f"{s}{d}") for d in dofs]))
    return groups


def split_part_columns(part_names: list[str]) -> list[np.ndarray]:
    """Per arm group (R shoulder, R elbow, L shoulder, L elbow) the likelihood's part columns
    it is weighted with: a shoulder's every part of its arm, an elbow's those below the
    upper arm (forearm, hand)."""
    cols = []
    for _, p in ARM_SIDES:
        side = [i for i, n in enumerate(part_names) if n.startswith(p)]
        cols.append(np.array(side))
        cols.append(np.array([i for i in side if not part_names[i].endswith("upper_arm")]))
    return cols


def split_log_lik(terms: np.ndarray, columns: list[np.ndarray], torso_prior, arm_prior: np.ndarray
                  ) -> np.ndarray:
    """``(N, 5)`` each group's log-weight (Schmidt eq. 10's factors ``terms (N, parts)``, log):
    the torso's the whole pose's plus the priors, an arm group's its ``columns``' terms plus its
    arm's (R, L: ``arm_prior (N, 2)``) twist log-prior."""
    out = [terms.sum(1) + torso_prior + arm_prior.sum(1)]
    for k, c in enumerate(columns):
        out.append(terms[:, c].sum(1) + arm_prior[:, k // 2])
    return np.column_stack(out)


def split_resample_indices(W: np.ndarray, mode: str, rng: np.random.Generator) -> np.ndarray:
    """``(N, 5)`` ancestor index per particle and group, from the groups' weights ``W (N, 5)``:
    ``groups``, each column drawn with its own weights (systematic); ``arm``, the torso's and
    the shoulders' drawn and each elbow's its shoulder's."""
    if mode == "groups":
        return kpf.partitioned_resample_indices(W, [None] * W.shape[1], rng)
    idx = kpf.partitioned_resample_indices(W[:, [0, 1, 3]], [None] * 3, rng)
    return idx[:, [0, 1, 1, 2, 2]]


def resample_indices(W: np.ndarray, groups: list[np.ndarray], split: str | None,
                     rng: np.random.Generator) -> np.ndarray:
    """The tracker's resampling indices: :func:`kpf.partitioned_resample_indices` (``split``
    None: the 1 or 3 groups, the draws as before) or :func:`split_resample_indices`."""
    if split is None:
        return kpf.partitioned_resample_indices(W, groups, rng)
    return split_resample_indices(W, split, rng)
