"""Menezes et al.'s two-arm 3-D tracker TBP (secs. 6.2-6.3): 8 arm DOFs, monocular, the
auxiliary particle filter with a skin first stage and shape + motion, colour patches and
priors in the second."""
