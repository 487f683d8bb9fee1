"""State estimation: filters turning noisy 3-D measurements into position, velocity and
acceleration (Ude & Atkeson's random-jerk Kalman filter)."""
