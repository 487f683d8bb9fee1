"""Small numerical building blocks shared by every tracker family (one implementation each).

* :mod:`~humimic.maths.stats` -- RMSE, NEES and its chi-square band;
* :mod:`~humimic.maths.kinematics` -- constant-acceleration prediction;
* :mod:`~humimic.maths.align` -- Umeyama alignment (none / se3 / sim3);
* :mod:`~humimic.maths.trajectory` -- APE/ATE and RPE as evo computes them, TUM files
  (``python -m humimic.evaluate``).

Camera projection and undistortion live in :mod:`humimic.sensors.camera_model`; rotations use
scipy's :class:`~scipy.spatial.transform.Rotation` (quaternions there are xyzw, MuJoCo's wxyz).
"""
