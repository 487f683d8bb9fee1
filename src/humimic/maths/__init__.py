"""Small numerical building blocks shared by every tracker family (one implementation each).

* :mod:`~humimic.maths.stats` -- RMSE, NEES and its chi-square band;
* :mod:`~humimic.maths.kinematics` -- constant-acceleration prediction.

Camera projection and undistortion live in :mod:`humimic.sensors.camera_model`; rotations use
scipy's :class:`~scipy.spatial.transform.Rotation` (quaternions there are xyzw, MuJoCo's wxyz).
"""
