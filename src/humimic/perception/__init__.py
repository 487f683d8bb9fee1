"""Vision: colour models, EM blob tracking, detection, ZNCC stereo matching (Ude & Atkeson)."""
