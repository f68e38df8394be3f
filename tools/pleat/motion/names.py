"""The naming schemes a source joint's name is read by: the Mixamo table, the common schemes' candidates (CMU BVH,
Biovision, Acclaim/CMU ASF) and namespace stripping. Both the structure match (pleat.motion.structure, where names
break ties) and the joint matching (pleat.motion.joint_map, which re-exports these names) read them, so they sit
below both.
"""
import re

# Mixamo's rig (FBX or BVH export, after the namespace) → the body's SMPL-style joints.
MIXAMO_TO_BODY = {
    "Hips": "pelvis", "Spine": "spine1", "Spine1": "spine2", "Spine2": "spine3", "Neck": "neck", "Head": "head",
    **{f"{S}{m}": f"{s}_{b}" for S, s in (("Left", "left"), ("Right", "right")) for m, b in (
        ("UpLeg", "hip"), ("Leg", "knee"), ("Foot", "ankle"), ("ToeBase", "foot"), ("Shoulder", "collar"),
        ("Arm", "shoulder"), ("ForeArm", "elbow"), ("Hand", "wrist"), ("HandMiddle1", "hand"))},
}

_SIDE_CANDIDATES = {
    "hip": ["{S}UpLeg", "{S}Hip", "{s}Thigh", "{S}Thigh", "{s}femur"],
    "knee": ["{S}Leg", "{S}Knee", "{s}Shin", "{S}Shin", "{s}tibia"],
    "ankle": ["{S}Foot", "{S}Ankle", "{s}Foot", "{s}foot"],
    "foot": ["{S}ToeBase", "{S}Toe", "{S}Toes", "{s}Toe", "{s}toes"],
    "collar": ["{S}Shoulder", "{S}Collar", "{s}Collar", "{s}clavicle"],
    "shoulder": ["{S}Arm", "{S}UpArm", "{S}UpperArm", "{s}Shldr", "{s}humerus"],
    "elbow": ["{S}ForeArm", "{S}Elbow", "{S}LowerArm", "{s}ForeArm", "{s}radius"],
    "wrist": ["{S}Hand", "{S}Wrist", "{s}Hand", "{s}wrist"],
    "hand": ["{S}HandMiddle1", "{S}HandIndex1", "{S}FingerBase", "{s}hand"],
}
_CENTER_CANDIDATES = {
    "pelvis": ["Hips", "hip", "Hip", "pelvis", "Pelvis", "root"],
    "spine1": ["Spine", "LowerBack", "lowerback", "Abdomen", "abdomen", "spine"],
    "spine2": ["Spine1", "Chest", "chest", "upperback"],
    "spine3": ["Spine2", "Chest2", "UpperChest", "thorax", "Spine3"],
    "neck": ["Neck", "neck", "lowerneck", "Neck1"],
    "head": ["Head", "head"],
}
_MIXAMO_PREFIX = re.compile(r"^mixamorig\d*[_:]", re.IGNORECASE)


def strip_namespace(name):
    """`mixamorig:LeftUpLeg`, `Armature|mixamorig:LeftUpLeg`, `mixamorig1_LeftUpLeg` → `LeftUpLeg`."""
    base = re.split(r"[:|]", str(name))[-1]
    base = _MIXAMO_PREFIX.sub("", base)
    return base or str(name)


def guess_joint_map(source_names, root=True):
    """Body joint → source joint by common naming schemes (CMU BVH, Mixamo, Biovision, Acclaim/CMU ASF), on names
    with their namespace stripped; with `root`, the pelvis is the first name (the skeleton's root)."""
    names = list(source_names)
    stripped = [strip_namespace(n) for n in names]
    exact = {}
    lower = {}
    for raw, s in zip(names, stripped):
        exact.setdefault(s, raw)
        lower.setdefault(s.lower(), raw)
    used, out = set(), {}

    def pick(cands):
        for c in cands:
            hit = exact.get(c) or lower.get(c.lower())
            if hit and hit not in used:
                return hit
        return None

    for joint, cands in _CENTER_CANDIDATES.items():
        hit = pick(cands)
        if hit:
            out[joint] = hit
            used.add(hit)
    for side, S, s in (("left", "Left", "l"), ("right", "Right", "r")):
        for part, cands in _SIDE_CANDIDATES.items():
            hit = pick([c.format(S=S, s=s) for c in cands])
            if hit:
                out[f"{side}_{part}"] = hit
                used.add(hit)
    if root and names:
        out["pelvis"] = names[0]
    return out
