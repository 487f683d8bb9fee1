"""Menezes et al. sec. 5.2: the upper-body tracker "ICU" (``kind: icu``) -- face detection and
recognition start it, ICONDENSATION on (u, v, s) with head-and-torso colour and the head-and-
shoulders silhouette follows the person, the Fig. 15 state machine re-initialises it."""
