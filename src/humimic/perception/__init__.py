"""Vision. ``blobs/``: Ude & Atkeson's colour-blob stereo tracker; ``cues/``: image cues shared
by every tracker (colour models, ...); ``reproduce``: the papers' tables and figures."""
