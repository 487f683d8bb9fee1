"""Mimicry: from (filtered) human motion to the humanoid's joints at the servo rate.

Ude & Atkeson, "Generation of humanoid motion from human motion": relative-motion mapping
(:mod:`.mapping`), Cartesian PD interpolation from the vision rate to the servo rate
(:mod:`.interpolation`), redundant IK keeping the head still (:mod:`.ik`), position servos with
feed-forward (:mod:`.servo`); beyond the paper, active gaze (:mod:`.gaze`). :mod:`.oracle` feeds
ground truth through the same ``estimates`` interface as the tracked perception pipeline.
"""
