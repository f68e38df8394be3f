"""Training / validation split of the shipped motion clips (docs/motion.md). Names are paths relative to the
motion folder, without suffix. Validation holds whole takes, never pieces of a training take:
- one long walk (long_walk3, 17.7 s) and one long stealthy walk (stealthy_walk1, 66 s) as unseen long takes;
  humanoid3d_stealthy_walk is a 4 s cut of stealthy_walk1 (its frames match stealthy_walk1's up to a constant
  root offset), so it goes with it;
- clip types that training never sees: punch, jog, sideflip, and one of the two dances (dance_b);
- one of the pybullet walker turns (turn_right1).
Everything else is training. Augmented variants (mirror, time scaling, root-path changes, concatenations) are made
from training clips only.
"""

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
