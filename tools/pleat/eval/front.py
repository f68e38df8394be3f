"""What both Pareto charts share (pleat.eval.pareto, pleat.eval.pareto_garments): the front itself, an asset's
sizes, and the motion their step times are taken on."""
import json

import numpy as np

from pleat.eval import scene as S


def pareto_front(points):
    """Indices of the points (time, error) that no other point beats on both (ties count as beaten)."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], float("inf")
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def motion_arrays(clip, joint_names):
    return (S.clip_rotations_for(clip, joint_names), clip.root_translation, clip.root_rotation, 1.0 / clip.fps)


def timing_clip(clip, frames=300):
    """The clip looped (forwards then backwards) to at least `frames` poses, for timing only."""
    idx = np.arange(frames) % (2 * clip.num_frames - 2 if clip.num_frames > 1 else 1)
    idx = np.where(idx >= clip.num_frames, 2 * clip.num_frames - 2 - idx, idx)
    return clip.frames_at(idx)


def describe_asset(weights):
    meta = {}
    try:
        meta = json.loads(weights.get("metadata_json") or "{}")
    except ValueError:
        pass
    lp = sorted(k for k in weights if k.startswith("lp.") and k.endswith(".weight"))
    dec = sorted(k for k in weights if k.startswith("dec.") and k.endswith(".weight"))
    return dict(vertices=int(len(weights["template"])), latent=int(len(weights["z_min"])),
                blend=int(len(weights["blend_shapes"])),
                lp_hidden=[int(weights[k].shape[0]) for k in lp[:-1]],
                dec_hidden=[int(weights[k].shape[0]) for k in dec[:-1]],
                model=meta.get("model") or ("lbs-only" if S.is_lbs_only(weights) else "network"),
                preset=meta.get("preset"), distillation=meta.get("distillation"))
