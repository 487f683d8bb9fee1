"""Sugiyama & Miura's wearable-interface estimators: EKFs sharing one motion model.

* :mod:`.motion_model` -- the interface state (p, q, v, ω, a, b), the random-jerk quaternion
  motion model (eqs. 3-4) and the inertial measurement models (eqs. 6-7);
* :mod:`.quaternion` -- quaternion Jacobians;
* :mod:`.inverse_depth` -- inverse-depth / XYZ map features and their projection (eqs. 8-9);
* :mod:`.update` -- EKF prediction and update on a large state whose models touch few columns;
* :mod:`.slam` -- the movement EKF SLAM (sec. III);
* :mod:`.arm` -- the Wii-remote arm EKF (sec. IV), its measurement models
  (:mod:`.arm_model`) and the marker in the image (:mod:`.arm_marker`).
"""
