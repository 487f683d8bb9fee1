"""Image cues any tracker uses: colour models learned per scenario (skin, shirt, marker)."""
