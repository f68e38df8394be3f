"""A source skeleton re-rooted at its hips: the joints above them go, their motion folded into the hips'.

Retargeting takes the source root's position and rotation as the body's pelvis. Many engine and DCC skeletons have a
root bone above the hips that is not part of the body: Unreal's `root` on the floor (it carries the root motion; the
pelvis moves relative to it), a DCC's armature or reference node. Read as the pelvis, such a root shifts the whole
spine by one joint and keeps the hips' own motion out of the clip. pleat.motion.structure.hips_joint finds the hips
from the legs; `rerooted` makes them the root:

    world rotation and position of the hips per frame (forward kinematics through the dropped joints, with their
    position channels) → the new root's rotation and position; the hips' subtree keeps its local rotations; every
    joint outside that subtree (the root, IK target bones such as Unreal's ik_foot_root) is dropped.
"""
from dataclasses import replace

import numpy as np


def subtree_order(parents, top):
    """The joints under `top`, `top` first, in the skeleton's own order (parents before children)."""
    keep = {int(top)}
    order = [int(top)]
    for s in range(int(top) + 1, len(parents)):
        if int(parents[s]) in keep:
            keep.add(s)
            order.append(s)
    return order


def rerooted(src, hips):
    """`src` (a SourceMotion whose parents come before their children) with `hips` as its root (see the module
    doc). hips = 0: src itself."""
    if hips == 0:
        return src
    W = src.world_rotations()
    P = src.world_positions(W)
    order = subtree_order(src.parents, hips)
    new_index = {s: i for i, s in enumerate(order)}
    parents = np.array([-1] + [new_index[int(src.parents[s])] for s in order[1:]], np.int64)
    local = src.local_rotations[:, order].copy()
    local[:, 0] = W[:, hips]
    dropped = [n for s, n in enumerate(src.names) if s not in new_index]
    out = replace(src, names=[src.names[s] for s in order], parents=parents,
                  rest_positions=np.asarray(src.rest_positions, np.float64)[order], local_rotations=local,
                  root_positions=P[:, hips].copy(),
                  joint_translations={new_index[s]: v for s, v in src.joint_translations.items()
                                      if s in new_index and s != hips},
                  source=f"{src.source}, re-rooted at {src.names[hips]} (dropped: {', '.join(dropped)})")
    for key in ("animated",):
        if hasattr(src, key):
            setattr(out, key, [getattr(src, key)[s] for s in order])
    if hasattr(src, "tips"):
        out.tips = {new_index[s]: v for s, v in src.tips.items() if s in new_index}
    out.dropped_above_hips = dropped
    return out
