"""Sensors and the clock: eye and head cameras, the IMU and the Wii remote, in simulated time."""
