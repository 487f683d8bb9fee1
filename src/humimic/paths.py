"""Where humimic finds its files (models, colour models, default scenarios)."""

from __future__ import annotations

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
PROJECT_DIR = PACKAGE_DIR.parent.parent
MODELS_DIR = PROJECT_DIR / "models"
SCENARIOS_DIR = PROJECT_DIR / "scenarios"
SHARED_DATA_DIR = PROJECT_DIR.parent / "shared" / "data"
