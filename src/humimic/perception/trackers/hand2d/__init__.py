"""Menezes et al. sec. 5.1: the 2-D hand tracker (``kind: hand2d``) -- config, measurement
model, detection, tracker, stage."""
