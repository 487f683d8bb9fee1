"""Faces: Haar detection, crops and eigenface recognition with a void class (Menezes secs. 4.2.1
and 5.2.1), plus the studio that renders the avatar's face for training and measurement.
The faces themselves (identities, textures) are part of the world: :mod:`humimic.world.faces`.
"""
