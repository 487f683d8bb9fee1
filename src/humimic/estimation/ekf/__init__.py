"""Sugiyama & Miura's extended Kalman filters (the wearable interface): the random-jerk
quaternion motion model shared by the head SLAM and the Wii-remote arm EKF
(:mod:`~humimic.estimation.ekf.jerk_model`), and the arm EKF (``arm*`` modules)."""
