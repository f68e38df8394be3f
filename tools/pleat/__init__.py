"""Pleat offline tools. The runtime SDK (sdk/) never imports any of this."""
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
ASSETS_DIR = REPO_ROOT / "assets"
__version__ = "0.1.0"
