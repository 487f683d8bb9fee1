"""State estimation: filters turning noisy measurements into states.

* :mod:`~humimic.estimation.random_jerk` -- Ude & Atkeson's random-jerk Kalman filter of 3-D
  points (the ``filter`` stage, :mod:`~humimic.estimation.stage`);
* :mod:`~humimic.estimation.ekf` -- Sugiyama & Miura's wearable interface: the movement EKF
  SLAM from the head camera and IMU (the ``slam`` stage);
* ``python -m humimic.estimation.reproduce`` -- their Table II, Fig. 8 and cycle times.
"""
