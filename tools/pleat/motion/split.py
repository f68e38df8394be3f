"""Training / validation split of the shipped motion clips (docs/motion.md). Names are paths relative to the
motion folder, without suffix. Validation holds whole takes, never pieces of a training take:
- one long walk (long_walk3, 17.7 s) and one long stealthy walk (stealthy_walk1, 66 s) as unseen long takes;
  humanoid3d_stealthy_walk is a 4 s cut of stealthy_walk1 (its frames match stealthy_walk1's up to a constant
  root offset), so it goes with it;
- clip types that training never sees: punch, jog, sideflip, and one of the two dances (dance_b);
- one of the pybullet walker turns (turn_right1).
Everything else is training. Augmented variants (mirror, time scaling, root-path changes, concatenations) are made
from training clips only.

A motion folder may lack some of these clips (scripts/fetch-motion.sh could not reach one of the sources):
`missing()` names them, and `available(split)` gives the clips of a split that are there, with one warning per
process naming the missing ones; it is an error only when none of the split is there.
"""
import sys

from pleat.cli import InputError

VALIDATION = (
    "deepmimic_github/humanoid3d_long_walk3",
    "deepmimic_github/humanoid3d_stealthy_walk1",
    "deepmimic_github/humanoid3d_stealthy_walk",
    "deepmimic_github/humanoid3d_jog",
    "deepmimic_github/humanoid3d_sideflip",
    "deepmimic_pybullet/humanoid3d_punch",
    "deepmimic_pybullet/humanoid3d_dance_b",
    "deepmimic_pybullet/walker/turn_right1",
)

TRAINING = (
    "deepmimic_github/humanoid3d_dance_spin",
    "deepmimic_github/humanoid3d_long_walk1",
    "deepmimic_github/humanoid3d_long_walk2",
    "deepmimic_github/humanoid3d_long_zombie",
    "deepmimic_github/humanoid3d_stealthy_walk0",
    "deepmimic_github/humanoid3d_zombie_walk",
    "deepmimic_pybullet/humanoid3d_backflip",
    "deepmimic_pybullet/humanoid3d_cartwheel",
    "deepmimic_pybullet/humanoid3d_crawl",
    "deepmimic_pybullet/humanoid3d_dance_a",
    "deepmimic_pybullet/humanoid3d_getup_facedown",
    "deepmimic_pybullet/humanoid3d_getup_faceup",
    "deepmimic_pybullet/humanoid3d_jump",
    "deepmimic_pybullet/humanoid3d_kick",
    "deepmimic_pybullet/humanoid3d_roll",
    "deepmimic_pybullet/humanoid3d_run",
    "deepmimic_pybullet/humanoid3d_spin",
    "deepmimic_pybullet/humanoid3d_spinkick",
    "deepmimic_pybullet/humanoid3d_walk",
    "deepmimic_pybullet/walker/0walk_forward",
    "deepmimic_pybullet/walker/turn_left0",
    "deepmimic_pybullet/walker/turn_left1",
    "deepmimic_pybullet/walker/turn_right0",
)


def split_of(name):
    if name in VALIDATION:
        return "validation"
    if name in TRAINING:
        return "training"
    return None


def names(split):
    """The clip names of "training" (or "train") or "validation"."""
    if split in ("training", "train"):
        return TRAINING
    if split == "validation":
        return VALIDATION
    raise ValueError(f"unknown split {split!r}: training or validation")


def _found(motion_dir=None):
    """(the motion folder or None, the clip names in it)."""
    from pleat.motion.loaders import find_motion_dir, list_clips
    try:
        root = motion_dir or find_motion_dir()
    except FileNotFoundError:
        return None, set()
    return root, set(list_clips(root))


def missing(motion_dir=None):
    """The split's clips (training, then validation) that the motion folder does not have: all of them when there is
    no motion folder."""
    _, found = _found(motion_dir)
    return [n for n in TRAINING + VALIDATION if n not in found]


_warned = set()


def available(split, motion_dir=None, required=True, warn=None):
    """The clips of `split` that are in the motion folder, in the split's order. When some of the split's clips (either
    split) are missing, says so once per process and folder through `warn` (default: a line on stderr), naming them
    all. required: an InputError when none of `split` is there; else an empty list."""
    want = names(split)
    root, found = _found(motion_dir)
    gone = [n for n in TRAINING + VALIDATION if n not in found]
    if gone and str(root) not in _warned:
        _warned.add(str(root))
        where = f"the motion folder {root}" if root else "any motion folder"
        message = (f"warning: {len(gone)} of the split's {len(TRAINING + VALIDATION)} clips are not in {where} and "
                   f"are left out: {', '.join(gone)} (scripts/fetch-motion.sh fetches them)")
        (warn or (lambda m: print(m, file=sys.stderr)))(message)
    have = [n for n in want if n in found]
    if required and not have:
        what = f"the {len(want)} {'training' if want is TRAINING else 'validation'} clips of the split"
        if root is None:
            raise InputError(None, f"no motion folder, so none of {what}: run scripts/fetch-motion.sh or set "
                                   "PLEAT_MOTION_DIR")
        raise InputError(root, f"has none of {what} (pleat.motion.split): run scripts/fetch-motion.sh or set "
                               "PLEAT_MOTION_DIR")
    return have
