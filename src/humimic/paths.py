"""Where humimic finds its files (models, colour models, default scenarios, real data)."""

from __future__ import annotations

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
PROJECT_DIR = PACKAGE_DIR.parent.parent
MODELS_DIR = PROJECT_DIR / "models"
SCENARIOS_DIR = PROJECT_DIR / "scenarios"
DATA_DIR = PROJECT_DIR / "data"
"""Real data shipped with the project (motion capture, trajectories); see data/README.md."""
