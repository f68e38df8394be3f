"""Where the tools find the project's files: the one place that knows the repository layout.

The root is $PLEAT_ROOT when set; else the checkout this package is imported from (tools/pleat inside a tree with
assets/); else the nearest folder at or above the working directory that has assets/body.npz; else the working
directory. So an installed package (pip install pleat-tools, outside the checkout) works from a project folder, or
anywhere with PLEAT_ROOT. Under the root: assets/ (body, shipped assets), data/ (fetched motion, generated garments),
out/ (caches and runs), configs/ (training presets).
"""
import os
from pathlib import Path


def _find_root():
    if os.environ.get("PLEAT_ROOT"):
        return Path(os.environ["PLEAT_ROOT"]).resolve()
    checkout = Path(__file__).resolve().parents[2]
    if (checkout / "tools" / "pleat").is_dir() and (checkout / "assets").is_dir():
        return checkout
    here = Path.cwd().resolve()
    for folder in (here, *here.parents):
        if (folder / "assets" / "body.npz").is_file():
            return folder
    return here


REPO_ROOT = _find_root()
ASSETS_DIR = REPO_ROOT / "assets"
DATA_DIR = REPO_ROOT / "data"
OUT_DIR = REPO_ROOT / "out"
CONFIGS_DIR = REPO_ROOT / "configs"
GARMENTS_DIR = DATA_DIR / "garments"
BODY_PATH = ASSETS_DIR / "body.npz"


def motion_dirs():
    """Motion folders in search order: $PLEAT_MOTION_DIR, ../shared/motion beside the root, data/motion."""
    dirs = [Path(os.environ["PLEAT_MOTION_DIR"])] if os.environ.get("PLEAT_MOTION_DIR") else []
    return dirs + [REPO_ROOT.parent / "shared" / "motion", DATA_DIR / "motion"]
