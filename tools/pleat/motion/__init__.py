"""Motion clips on the Pleat body: loaders (DeepMimic, BVH, ASF/AMC, AMASS), retargeting, resampling,
augmentation and the training/validation split (docs/motion.md)."""
from pleat.motion.clip import Clip, concatenate, identity_clip
from pleat.motion.joint_map import JointMatch, match_joints, read_joint_map_file
from pleat.motion.loaders import (MotionFileError, find_motion_dir, list_clips, load_amass, load_asf_amc, load_bvh,
                                  load_clip, load_clip_at, load_deepmimic, motion_dirs)
from pleat.motion.retarget import SourceMotion, retarget

__all__ = ["Clip", "concatenate", "identity_clip", "find_motion_dir", "list_clips", "load_clip", "load_deepmimic",
           "load_bvh", "load_asf_amc", "load_amass", "motion_dirs", "SourceMotion", "retarget",
           "MotionFileError", "load_clip_at", "JointMatch", "match_joints", "read_joint_map_file"]
