"""Synthetic BVH skeletons in the common naming schemes, built from the Pleat body's rest joints (so a right match
must come out with the source's bone directions exactly): Mixamo, Biovision, CMU, 3ds Max Biped, Unreal's mannequin
and the body's own names; in the body's A-pose, in a T-pose or with the arms hanging down; with a few frames of known
motion. Each joint has a role, the body joint it stands for (None: an extra joint such as Biped's `Bip01 Pelvis`),
and the motion is given per role, so every scheme moves the same way."""
import numpy as np

SIDES = (("left", "Left", "L", "l", 1.0), ("right", "Right", "R", "r", -1.0))


def _side_joints(scheme, side, Side, S, s):
    """(name, role, parent role) for one side's leg and arm, per scheme; roles are body joint names."""
    leg = {"mixamo": ["UpLeg", "Leg", "Foot", "ToeBase"], "cmu": ["UpLeg", "Leg", "Foot", "ToeBase"],
           "biovision": ["Hip", "Knee", "Ankle", None]}
    arm = {"mixamo": ["Shoulder", "Arm", "ForeArm", "Hand", "HandMiddle1"],
           "cmu": ["Shoulder", "Arm", "ForeArm", "Hand", "FingerBase"],
           "biovision": ["Collar", "Shoulder", "Elbow", "Wrist", None]}
    roles_leg = ["hip", "knee", "ankle", "foot"]
    roles_arm = ["collar", "shoulder", "elbow", "wrist", "hand"]
    if scheme in leg:
        legs = [(f"{Side}{n}" if n else None) for n in leg[scheme]]
        arms = [(f"{Side}{n}" if n else None) for n in arm[scheme]]
    elif scheme == "biped":
        legs = [f"Bip01 {S} {n}" for n in ("Thigh", "Calf", "Foot", "Toe0")]
        arms = [f"Bip01 {S} {n}" for n in ("Clavicle", "UpperArm", "Forearm", "Hand", "Finger2")]
    elif scheme == "unreal":
        legs = [f"{n}_{s}" for n in ("thigh", "calf", "foot", "ball")]
        arms = [f"{n}_{s}" for n in ("clavicle", "upperarm", "lowerarm", "hand", "middle_01")]
    else:   # the body's own names
        legs = [f"{side}_{r}" for r in roles_leg]
        arms = [f"{side}_{r}" for r in roles_arm]
    out = []
    for names, roles in ((legs, roles_leg), (arms, roles_arm)):
        for n, r in zip(names, roles):
            if n:
                out.append((n, f"{side}_{r}"))
    return out


CENTER = {
    "mixamo": [("Hips", "pelvis"), ("Spine", "spine1"), ("Spine1", "spine2"), ("Spine2", "spine3"), ("Neck", "neck"),
               ("Head", "head")],
    "cmu": [("Hips", "pelvis"), ("LowerBack", "spine1"), ("Spine", "spine2"), ("Spine1", "spine3"),
            ("Neck", "neck"), ("Neck1", None), ("Head", "head")],
    "biovision": [("Hips", "pelvis"), ("Chest", "spine2"), ("Chest2", "spine3"), ("Neck", "neck"), ("Head", "head")],
    "biped": [("Bip01", "pelvis"), ("Bip01 Pelvis", None), ("Bip01 Spine", "spine1"), ("Bip01 Spine1", "spine2"),
              ("Bip01 Spine2", "spine3"), ("Bip01 Neck", "neck"), ("Bip01 Head", "head")],
    "unreal": [("pelvis", "pelvis"), ("spine_01", "spine1"), ("spine_02", "spine2"), ("spine_03", "spine3"),
               ("neck_01", "neck"), ("head", "head")],
    "body": [(n, n) for n in ("pelvis", "spine1", "spine2", "spine3", "neck", "head")],
}
SCHEMES = tuple(CENTER)


def rest_points(body, pose):
    """Rest positions (cm, pelvis 95 cm above the origin) of every body joint in `pose`: "A" (the body's own wide
    A-pose), "T" (arms straight out sideways) or "down" (arms hanging 80° below the horizontal)."""
    J = body.joints()
    names = list(body.joint_names)
    P = {n: (J[i] - J[0]) * 100.0 + np.array([0.0, 95.0, 0.0]) for i, n in enumerate(names)}
    if pose != "A":
        for side, *_, x in SIDES:
            chain = [f"{side}_{j}" for j in ("shoulder", "elbow", "wrist", "hand")]
            down = np.radians({"T": 0.0, "down": 80.0}[pose])
            d = np.array([x * np.cos(down), -np.sin(down), 0.0])
            new = {chain[0]: P[chain[0]]}
            for a, b in zip(chain[:-1], chain[1:]):
                new[b] = new[a] + d * np.linalg.norm(P[b] - P[a])
            P.update(new)
    return P


def arm_down_deg(pose):
    """How far below the horizontal a rest pose holds the upper arm."""
    return {"A": 25.0, "T": 0.0, "down": 80.0}[pose]


def skeleton(body, scheme, pose):
    """[(name, role, parent index, rest position cm)] in BVH order (parents first), then the end sites."""
    P = rest_points(body, pose)
    centre = CENTER[scheme]
    joints = []
    index = {}

    def add(name, role, parent, pos):
        index[name] = len(joints)
        joints.append((name, role, parent, np.asarray(pos, np.float64)))

    prev = None
    for name, role in centre:
        if role is None:     # an extra joint: Bip01 Pelvis on the root, Neck1 halfway up the neck
            pos = P["pelvis"] if scheme == "biped" else 0.5 * (P["neck"] + P["head"])
        else:
            pos = P[role]
        add(name, role, None if prev is None else index[prev], pos)
        prev = name
    by_role = {role: name for name, role in centre if role}
    leg_parent = "Bip01 Spine" if scheme == "biped" else by_role["pelvis"]
    arm_parent = "Bip01 Neck" if scheme == "biped" else by_role["spine3"]
    for side, Side, S, s, x in SIDES:
        last = None
        for name, role in _side_joints(scheme, side, Side, S, s):
            part = role.split("_", 1)[1]
            if part in ("hip", "collar"):
                parent = leg_parent if part == "hip" else arm_parent
            else:
                parent = last
            add(name, role, index[parent], P[role])
            last = name
    ends = []
    # end sites: the top of the head, toe tips, finger tips (or the hand when the scheme stops at the wrist)
    ends.append((index[by_role["head"]], P["head"] + [0.0, 18.0, 0.0]))
    for side, *_ in SIDES:
        by = {role: i for i, (n, role, *_r) in enumerate(joints) if role}
        last_leg = by.get(f"{side}_foot", by[f"{side}_ankle"])
        ends.append((last_leg, (P[f"{side}_foot"] + [0.0, 0.0, 6.0]) if f"{side}_foot" in by else P[f"{side}_foot"]))
        last_arm = by.get(f"{side}_hand", by[f"{side}_wrist"])
        tip = P[f"{side}_hand"] + 8.0 * (P[f"{side}_hand"] - P[f"{side}_wrist"]) / np.linalg.norm(
            P[f"{side}_hand"] - P[f"{side}_wrist"]) if f"{side}_hand" in by else P[f"{side}_hand"]
        ends.append((last_arm, tip))
    return joints, ends


def motion(pose, frames=4):
    """Per frame, {role: (axis, degrees)} local rotations and the root position (cm): standing in the rest pose,
    then a knee bend, a spine bend, arms lowered to 45° below the horizontal and elbows bent forward, a turn."""
    lower = 45.0 - arm_down_deg(pose)
    out = []
    for t in range(frames):
        rot = {}
        if t >= 1:
            rot["left_knee"] = ("X", 50.0)
            rot["spine2"] = ("X", 10.0)
            rot["left_shoulder"] = ("Z", -lower)
            rot["right_shoulder"] = ("Z", lower)
        if t >= 2:
            rot["right_knee"] = ("X", 30.0)
            rot["left_elbow"] = ("Y", -30.0)
            rot["right_elbow"] = ("Y", 30.0)
            rot["neck"] = ("X", 15.0)
        if t >= 3:
            rot["pelvis"] = ("Y", 30.0)
            rot["left_collar"] = ("Z", 10.0)
            rot["right_collar"] = ("Z", -10.0)
        out.append((rot, np.array([0.0, 95.0, 5.0 * t])))
    return out


def bvh_text(body, scheme, pose, frames=4):
    """The BVH file of `scheme` in rest pose `pose` with `motion(pose)`; Zrotation Xrotation Yrotation channels."""
    joints, ends = skeleton(body, scheme, pose)
    children = {i: [] for i in range(len(joints))}
    for i, (_, _, parent, _) in enumerate(joints):
        if parent is not None:
            children[parent].append(i)
    end_of = {}
    for parent, pos in ends:
        end_of.setdefault(parent, []).append(pos)
    lines = ["HIERARCHY"]

    order = []       # the motion rows list channels in the order the hierarchy declares the joints

    def write(i, depth):
        order.append(i)
        name, _, parent, pos = joints[i]
        off = pos if parent is None else pos - joints[parent][3]
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if parent is None else 'JOINT'} {name}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {off[0]:.6f} {off[1]:.6f} {off[2]:.6f}")
        lines.append(f"{pad}  CHANNELS {6 if parent is None else 3} "
                     + ("Xposition Yposition Zposition " if parent is None else "")
                     + "Zrotation Xrotation Yrotation")
        for c in children[i]:
            write(c, depth + 1)
        for e in end_of.get(i, []):
            d = e - pos
            lines.extend([f"{pad}  End Site", pad + "  {", f"{pad}    OFFSET {d[0]:.6f} {d[1]:.6f} {d[2]:.6f}",
                          pad + "  }"])
        if not children[i] and i not in end_of:
            lines.extend([f"{pad}  End Site", pad + "  {", f"{pad}    OFFSET 0 2 0", pad + "  }"])
        lines.append(pad + "}")

    write(0, 0)
    rows = []
    for rot, root in motion(pose, frames):
        vals = []
        for name, role, parent, _ in (joints[i] for i in order):
            if parent is None:
                vals += list(root)
            z = x = y = 0.0
            if role in rot:
                axis, deg = rot[role]
                z, x, y = (deg if axis == a else 0.0 for a in "ZXY")
            vals += [z, x, y]
        rows.append(" ".join(f"{v:.6f}" for v in vals))
    return "\n".join(lines) + f"\nMOTION\nFrames: {len(rows)}\nFrame Time: 0.0333333\n" + "\n".join(rows) + "\n"


def expected_map(body, scheme):
    """Body joint → source joint that a right match gives."""
    joints, _ = skeleton(body, scheme, "A")
    return {role: name for name, role, *_ in joints if role}


def with_floor_root(text, pelvis_positions=False, ik_bones=True):
    """`text` (a bvh_text file) under an engine's root bone on the floor, as Unreal's skeletons are: `root` at the
    origin carries the ground motion, and the former root (the pelvis) hangs from it at its rest height. With
    pelvis_positions the pelvis keeps its own position channels and the root stands still (the other common export);
    else the root carries the horizontal path and the pelvis rotates only. ik_bones adds Unreal's IK target bones under
    the root (ik_foot_root with ik_foot_l / ik_foot_r at the ankles, ik_hand_root with ik_hand_gun), which are not
    part of the body. The motion is the same as `text`'s."""
    head, motion = text.split("MOTION\n")
    lines = head.strip().split("\n")
    pelvis_offset = [float(v) for v in lines[3].split()[1:4]]          # the former ROOT's OFFSET: its rest position
    out = ["HIERARCHY", "ROOT root", "{", "  OFFSET 0 0 0",
           "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    ik_columns = 0
    if ik_bones:
        out += ["  JOINT ik_foot_root", "  {", "    OFFSET 0 0 0", "    CHANNELS 3 Zrotation Xrotation Yrotation"]
        for name, x in (("ik_foot_l", 9.0), ("ik_foot_r", -9.0)):
            out += [f"    JOINT {name}", "    {", f"      OFFSET {x} 8 0", "      CHANNELS 3 Zrotation Xrotation "
                    "Yrotation", "      End Site", "      {", "        OFFSET 0 0 4", "      }", "    }"]
        out += ["  }", "  JOINT ik_hand_root", "  {", "    OFFSET 0 0 0", "    CHANNELS 3 Zrotation Xrotation Yrotation",
                "    JOINT ik_hand_gun", "    {", "      OFFSET 30 100 10", "      CHANNELS 3 Zrotation Xrotation "
                "Yrotation", "      End Site", "      {", "        OFFSET 0 0 4", "      }", "    }", "  }"]
        ik_columns = 5 * 3
    for i, line in enumerate(lines[1:]):
        if i == 0:
            line = line.replace("ROOT", "JOINT")
        elif i == 3 and not pelvis_positions:
            line = line.replace("CHANNELS 6 Xposition Yposition Zposition", "CHANNELS 3")
        out.append("  " + line)
    out.append("}")
    header, rows = motion.strip().split("\n")[:2], motion.strip().split("\n")[2:]
    new_rows = []
    for row in rows:
        v = [float(x) for x in row.split()]
        pos, rest = v[:3], v[3:]
        if pelvis_positions:
            new = [0.0] * 6 + [0.0] * ik_columns + pos + rest
        else:   # the root carries the path (the pelvis's height stays in its offset), the pelvis its rotation
            new = [pos[0], pos[1] - pelvis_offset[1], pos[2], 0.0, 0.0, 0.0] + [0.0] * ik_columns + rest
        new_rows.append(" ".join(f"{x:.6f}" for x in new))
    return "\n".join(out) + "\nMOTION\n" + "\n".join(header) + "\n" + "\n".join(new_rows) + "\n"


# A bvh_text file (+Y up, channels Z X Y) standing along another axis: its positions (x, y, z) → `position`, and each
# rotation channel about an axis becomes one about the turned axis (signed), in the same order.
TURNS = {
    "+Z": dict(position=lambda x, y, z: (x, -z, y), channels=(("Y", -1.0), ("X", 1.0), ("Z", 1.0))),
    "-X": dict(position=lambda x, y, z: (-y, x, z), channels=(("Z", 1.0), ("Y", 1.0), ("X", -1.0))),
}


def turned(text, axis):
    """`text` re-expressed with `axis` (a TURNS key) as its up axis: the same skeleton and motion, turned."""
    turn = TURNS[axis]
    head, motion = text.split("MOTION\n")

    def offset(m):
        return "OFFSET " + " ".join(f"{v:.6f}" for v in turn["position"](*(float(g) for g in m.groups())))
    import re
    head = re.sub(r"OFFSET (\S+) (\S+) (\S+)", offset, head)
    rot = " ".join(f"{a}rotation" for a, _ in turn["channels"])
    head = head.replace("Zrotation Xrotation Yrotation", rot)
    lines = motion.strip().split("\n")
    rows = []
    for line in lines[2:]:
        v = [float(x) for x in line.split()]
        v[:3] = turn["position"](*v[:3])
        for k in range(3, len(v), 3):
            v[k:k + 3] = [sign * value for (_, sign), value in zip(turn["channels"], v[k:k + 3])]
        rows.append(" ".join(f"{x:.6f}" for x in v))
    return head + "MOTION\n" + "\n".join(lines[:2]) + "\n" + "\n".join(rows) + "\n"
