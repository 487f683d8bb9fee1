"""Named, independent random generators derived from the scenario seed.

Each component gets its own stream (``SeedSequence(seed, spawn_key=(crc32(name),))``), so
adding a component or drawing more numbers in one never shifts another's randomness.
"""

from __future__ import annotations

import zlib

import numpy as np


def named_rng(seed: int, name: str) -> np.random.Generator:
    ss = np.random.SeedSequence(seed, spawn_key=(zlib.crc32(name.encode()),))
    return np.random.Generator(np.random.PCG64(ss))


class Rngs(dict):
    """``rngs["cameras"]`` creates (once) and returns the generator named ``cameras``."""

    def __init__(self, seed: int):
        super().__init__()
        self.seed = seed

    def __missing__(self, name: str) -> np.random.Generator:
        rng = named_rng(self.seed, name)
        self[name] = rng
        return rng
