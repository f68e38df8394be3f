"""Pleat offline tools. The runtime SDK (sdk/) never imports any of this."""
from pleat.paths import ASSETS_DIR, REPO_ROOT  # noqa: F401  (the one repository lookup: pleat.paths)

__version__ = "0.1.0"
