"""Menezes et al.'s 3-D hand tracker GEST (sec. 6.1): a free hand ellipsoid, ICONDENSATION
with a stereo skin-blob importance function, shape and colour likelihoods."""
