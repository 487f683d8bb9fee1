"""Ude & Atkeson's colour-blob stereo tracker: EM blobs (eqs. 1-7), automatic detection
(eqs. 8-9), identity, ZNCC stereo and triangulation (eq. 10), and its pipeline stage."""
