"""Sugiyama & Miura's wearable-interface estimators: EKFs sharing one motion model.

* :mod:`.motion_model` -- the interface state (p, q, v, ω, a, b), the random-jerk quaternion
  motion model (eqs. 3-4) and the inertial measurement models (eqs. 6-7);
* :mod:`.quaternion` -- quaternion Jacobians;
* :mod:`.inverse_depth` -- inverse-depth / XYZ map features and their projection (eqs. 8-9);
* :mod:`.update` -- EKF prediction and update on a large state whose models touch few columns;
* :mod:`.slam` -- the movement EKF SLAM (sec. III), with :mod:`.compressed` (the IMU steps'
  deferred map update) and :mod:`.state_blocks` (growing and converting the map);
* :mod:`.frontend`, :mod:`.arm_mask` -- its image side; :mod:`.estimator` -- the whole
  estimator; :mod:`.slam_stage` -- the pipeline stage (``slam:``, ``head_pose``, ``slam.*``);
* :mod:`.arm` -- the Wii-remote arm EKF (sec. IV), its measurement models (:mod:`.arm_model`),
  the marker in the image (:mod:`.arm_marker`), the head pose it reads (:mod:`.head_track`) and
  its stage (:mod:`.arm_stage`: ``arm:``, ``arm_pose``, ``arm.*``).
"""
