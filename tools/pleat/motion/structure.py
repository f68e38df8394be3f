"""Which source joint is which body joint, from the skeleton's shape (docs/motion.md, "How joints are matched").

Names lie: Biovision's `LeftShoulder` is the upper arm where Mixamo's is the clavicle, and a table read the wrong
way round turns an upper-arm rotation into a clavicle rotation without any error. The rest skeleton cannot lie in
that way, so the match is made from it, and names only break ties:

- **legs**: the two lowest leaves whose common ancestor is well above them (two toes of one foot meet at the foot);
  each leg chain runs from that ancestor (the leg fork) down to the leaf farthest from it;
- **sides**: the lateral axis is the line between the two legs; which side is left comes from the toes (feet point
  forward, and left = up × forward, as the body faces +Z with its left at +X), then from the names (Left, L, _l),
  then from the assumption that the file faces +Z (or +X when its hips are apart along Z);
- **spine and head**: the path from the root to the highest leaf outside the legs and away from the sides; the
  head is where its longest segment above the arms starts (the skull, longer than the neck and the end-site tip),
  and the joints below are given to spine1, spine2, spine3 and neck by their height between pelvis and head,
  matched in order to the body's (a skeleton with two spine joints gives them to the body joints at those heights);
- **arms**: per side, the branch off the spine path that reaches farthest sideways, run to its farthest leaf (the
  middle finger's tip when there are fingers);
- **in a limb chain**, the two longest consecutive segments are the upper and lower limb (thigh and shin, upper arm
  and forearm): their joints are hip/knee/ankle (shoulder/elbow/wrist), the joint after is the foot (hand), and in
  an arm the joint before the upper arm is the collar. A clavicle is short next to the upper arm and forearm, so a
  `LeftShoulder` that starts the long bone is the upper arm whatever its name says. When two pairs are within 10 %
  of each other, the names decide.

The body's pelvis is always the source root (retargeting takes the root's position and rotation as the pelvis's).
`structure_map` returns what it found; anything it cannot find is left out, and the name tables fill the gaps.
"""
import re

import numpy as np

from pleat.motion.names import MIXAMO_TO_BODY, guess_joint_map, strip_namespace

UP = np.array([0.0, 1.0, 0.0])
LIMB_TIE = 0.10              # two pairs of segments within 10 % of each other: the names decide
SPINE_BODY = ("spine1", "spine2", "spine3", "neck")
SKIP_SOURCE = 0.08           # cost of leaving a source spine joint unused (its rotation still reaches its children)
SKIP_BODY = 0.15             # cost of leaving a body spine joint without a source joint (it moves with its parent)

def name_side(name):
    """+1 when a joint name says left, −1 right, 0 neither (or both): `LeftArm`, `Bip01 L Thigh`, `thigh_l`,
    `lfemur`, `left_hip`."""
    n = strip_namespace(name)
    lo = n.lower()
    if lo.startswith("left") or "left" in lo:
        return 1
    if lo.startswith("right") or "right" in lo:
        return -1
    parts = re.split(r"[\s_.\-]+", n)
    if "L" in parts or "l" in parts[1:]:
        return 1
    if "R" in parts or "r" in parts[1:]:
        return -1
    # Acclaim's lfemur / rhumerus: a lone l/r before a lower-case word
    if re.match(r"^l[a-z]{3,}$", n):
        return 1
    if re.match(r"^r[a-z]{3,}$", n) and not n.startswith(("root", "radius")):
        return -1
    return 0


class _Skeleton:
    def __init__(self, parents, rest, candidate, tips):
        self.parents = np.asarray(parents, np.int64)
        self.rest = np.asarray(rest, np.float64)
        self.candidate = list(candidate)
        self.children = [[] for _ in self.parents]
        for s, p in enumerate(self.parents):
            if p >= 0:
                self.children[p].append(s)
        self.tips = dict(tips or {})          # childless joint → the end of its bone (ASF)
        self.depth = np.zeros(len(self.parents), np.int64)
        for s, p in enumerate(self.parents):
            self.depth[s] = 0 if p < 0 else self.depth[p] + 1

    def path(self, a, b):
        """Joints from a down to b (b a descendant of a), both included."""
        out = [b]
        while out[-1] != a:
            p = self.parents[out[-1]]
            if p < 0:
                return None
            out.append(int(p))
        return out[::-1]

    def ancestors(self, s):
        out = []
        while s >= 0:
            out.append(int(s))
            s = self.parents[s]
        return out

    def lca(self, a, b):
        up = set(self.ancestors(a))
        for s in self.ancestors(b):
            if s in up:
                return s
        return 0

    def subtree(self, s):
        out, stack = [], [s]
        while stack:
            j = stack.pop()
            out.append(j)
            stack.extend(self.children[j])
        return out

    def leaves(self, within=None):
        pool = range(len(self.parents)) if within is None else within
        return [s for s in pool if not self.children[s]]

    def point(self, s):
        """Where the chain through s ends: a leaf's bone end when known (ASF), else the joint."""
        return self.tips.get(s, self.rest[s])


def _limb(sk, chain, names, part_names):
    """chain: joints from the attach joint (on the spine) to the limb's far leaf → {part: source index} for the
    parts (upper, lower, end, next, before) of one limb, by its two longest consecutive segments."""
    pts = [sk.rest[s] for s in chain]
    ids = list(chain)
    if chain[-1] in sk.tips:
        pts.append(sk.tips[chain[-1]])
        ids.append(None)
    seg = [float(np.linalg.norm(pts[i + 1] - pts[i])) for i in range(len(pts) - 1)]
    pairs = []
    for i in range(1, len(seg) - 1):
        if sk.candidate[ids[i]] and ids[i + 1] is not None and sk.candidate[ids[i + 1]]:
            pairs.append((seg[i] + seg[i + 1], i))
    if not pairs:
        return {}
    pairs.sort(reverse=True)
    best = pairs[0][1]
    close = [i for v, i in pairs if v >= (1.0 - LIMB_TIE) * pairs[0][0]]
    if len(close) > 1:
        # a tie: the pair whose first joint's name is the upper limb's in some naming scheme
        named = set(guess_joint_map([names[ids[i]] for i in close], root=False).values())
        for i in close:
            if names[ids[i]] in named and any(p in names[ids[i]].lower() for p in part_names):
                best = i
                break
    out = {"upper": ids[best], "lower": ids[best + 1]}
    if best + 2 < len(ids) and ids[best + 2] is not None and sk.candidate[ids[best + 2]]:
        end = out["end"] = ids[best + 2]
        # the hand (foot) joint: the child that carries on the forearm's (shin's) line — the middle finger, the
        # toes — among those that are bones themselves; names decide between equally straight ones
        along = sk.rest[end] - sk.rest[ids[best + 1]]
        along /= max(np.linalg.norm(along), 1e-12)
        nexts = []
        for c in sk.children[end]:
            if sk.candidate[c] and (sk.children[c] or c in sk.tips):
                d = sk.rest[c] - sk.rest[end]
                if np.linalg.norm(d) > 1e-9:
                    nexts.append((float(np.dot(d / np.linalg.norm(d), along)), c))
        if nexts:
            nexts.sort(reverse=True)
            straight = [c for v, c in nexts if v >= nexts[0][0] - 0.02]
            named = set(guess_joint_map([names[c] for c in straight], root=False).values())
            named |= {names[c] for c in straight if MIXAMO_TO_BODY.get(strip_namespace(names[c]), "").endswith(
                ("_hand", "_foot"))}
            out["next"] = next((c for c in straight if names[c] in named), straight[0])
    if best - 1 >= 1 and sk.candidate[ids[best - 1]]:
        out["before"] = ids[best - 1]
    return out


def _spine_assignment(frac_src, frac_body):
    """Monotone alignment of source spine joints (heights frac_src, in order) to the body's (frac_body) that
    minimises |height difference| plus SKIP_* per joint left out → {body index: source index}."""
    n, m = len(frac_src), len(frac_body)
    cost = np.full((n + 1, m + 1), np.inf)
    move = {}
    cost[0, 0] = 0.0
    for i in range(n + 1):
        for j in range(m + 1):
            if i == 0 and j == 0:
                continue
            options = []
            if i > 0 and j > 0:
                options.append((cost[i - 1, j - 1] + abs(frac_src[i - 1] - frac_body[j - 1]), (i - 1, j - 1, True)))
            if i > 0:
                options.append((cost[i - 1, j] + SKIP_SOURCE, (i - 1, j, False)))
            if j > 0:
                options.append((cost[i, j - 1] + SKIP_BODY, (i, j - 1, False)))
            cost[i, j], move[i, j] = min(options, key=lambda o: o[0])
    out, i, j = {}, n, m
    while i or j:
        pi, pj, matched = move[i, j]
        if matched:
            out[j - 1] = i - 1
        i, j = pi, pj
    return out


def _height(sk):
    ys = [sk.point(s)[1] for s in range(len(sk.parents))]
    return float(max(ys) - min(ys))


def _leg_tips(sk, height):
    """The two leaves that end the legs: low leaves whose common ancestor is well above both (two toes of one foot
    meet at the foot; an engine's IK target bones, such as Unreal's ik_foot_l under ik_foot_root, meet at a root on
    the floor). The lowest such pair, or None."""
    if height <= 0:
        return None
    by_low = sorted(sk.leaves(), key=lambda s: sk.point(s)[1])
    for i, a in enumerate(by_low[:8]):
        for b in by_low[i + 1:]:
            meet = sk.rest[sk.lca(a, b)][1]
            if meet > max(sk.point(a)[1], sk.point(b)[1]) + 0.3 * height:
                return a, b
    return None


def leg_fork(parents, rest, tips=None):
    """The joint both legs hang from (the common ancestor of their tips), or None when no legs are found."""
    sk = _Skeleton(parents, rest, [True] * len(parents), tips)
    pair = _leg_tips(sk, _height(sk))
    return None if pair is None else int(sk.lca(*pair))


# A joint above the hips farther from them than this share of the skeleton's height is not part of the body: an
# engine's root bone on the floor (Unreal's `root`, a DCC's armature or reference node).
ROOT_OFF_BODY = 0.15


def hips_joint(parents, rest, tips=None):
    """The source joint that stands for the body's pelvis: the joint where the legs fork, or the highest of its
    ancestors that sit with it (3ds Max Biped's thighs hang from `Bip01 Spine`, a few centimetres above `Bip01`, the
    root, which is the pelvis). A root above that, farther from the hips than ROOT_OFF_BODY of the skeleton's
    height (Unreal's `root` on the floor), is not: the returned joint is then not the root, and the skeleton is
    re-rooted there before retargeting (pleat.motion.reroot). None when no legs are found."""
    sk = _Skeleton(parents, rest, [True] * len(parents), tips)
    height = _height(sk)
    pair = _leg_tips(sk, height)
    if pair is None:
        return None
    fork = hips = int(sk.lca(*pair))
    while sk.parents[hips] >= 0 and np.linalg.norm(sk.rest[sk.parents[hips]] - sk.rest[fork]) <= ROOT_OFF_BODY * height:
        hips = int(sk.parents[hips])
    return int(hips)


def structure_map(names, parents, rest, body, candidate=None, tips=None):
    """Body joint name → source joint name from the rest skeleton (see the module doc), plus notes: a dict with
    "sides" (how left was told from right: "toes", "names" or "assumed facing"), "forward" (the source's rest
    facing, a unit vector) and "ties" (limbs where the names decided). Raises nothing: what is not found is
    missing from the map."""
    names = list(names)
    S = len(names)
    if candidate is None:
        candidate = [True] * S
    candidate = list(candidate)
    candidate[0] = True
    sk = _Skeleton(parents, rest, candidate, tips)
    notes = {"sides": None, "forward": None}
    out = {"pelvis": names[0]}
    if S < 5:
        return out, notes
    pos = sk.rest
    leaves = sk.leaves()
    if len(leaves) < 3:
        return out, notes
    # ---- legs: two low leaves that meet high up (not two toes of one foot) ------------------------------------
    height = _height(sk)
    pair = _leg_tips(sk, height)
    if pair is None:
        return out, notes
    a, b = pair
    fork = sk.lca(a, b)
    legs = []
    for tip in (a, b):
        branch_root = sk.path(fork, tip)[1]
        sub = sk.subtree(branch_root)
        far = max(sk.leaves(sub), key=lambda s: (np.linalg.norm(sk.point(s) - pos[fork]), -pos[s][1]))
        legs.append((sub, sk.path(fork, far)))
    lateral = np.mean(pos[legs[0][0]], axis=0) - np.mean(pos[legs[1][0]], axis=0)
    lateral[1] = 0.0
    if np.linalg.norm(lateral) < 1e-9:
        return out, notes
    lateral /= np.linalg.norm(lateral)
    forward0 = np.cross(lateral, UP)              # forward if legs[0] is the left leg
    leg_parts = [_limb(sk, chain, names, ("thigh", "upleg", "hip", "femur")) for _, chain in legs]
    # ---- which leg is left: toes point forward; else the names; else the file faces +Z (or +X) --------------
    toes = 0.0
    for (_, chain), parts in zip(legs, leg_parts):
        if "end" in parts:
            ankle = pos[parts["end"]]
            toes += float(np.dot(sk.point(chain[-1]) - ankle, forward0))
    foot_scale = 0.05 * height
    if abs(toes) > foot_scale:
        first_is_left = toes > 0
        notes["sides"] = "toes"
    else:
        said = sum(name_side(names[s]) for s in legs[0][0]) - sum(name_side(names[s]) for s in legs[1][0])
        if said != 0:
            first_is_left = said > 0
            notes["sides"] = "names"
        else:
            # the file faces +Z (left at +X), or +X (left at −Z) when its hips are apart along Z
            axis = 0 if abs(lateral[0]) >= abs(lateral[2]) else 2
            first_is_left = (lateral[axis] > 0) == (axis == 0)
            notes["sides"] = "assumed facing"
    left_axis = lateral if first_is_left else -lateral
    forward = np.cross(left_axis, UP)
    notes["forward"] = forward
    leg_order = (("left", 0), ("right", 1)) if first_is_left else (("left", 1), ("right", 0))
    for side, k in leg_order:
        parts = leg_parts[k]
        for part, body_part in (("upper", "hip"), ("lower", "knee"), ("end", "ankle"), ("next", "foot")):
            if part in parts:
                out[f"{side}_{body_part}"] = names[parts[part]]
    leg_joints = set(legs[0][0]) | set(legs[1][0])

    # ---- spine: root to the highest leaf outside the legs, away from the sides --------------------------------
    rest_leaves = [s for s in leaves if s not in leg_joints]
    if not rest_leaves:
        return out, notes
    top = max(rest_leaves, key=lambda s: sk.point(s)[1] - abs(np.dot(sk.point(s) - pos[0], left_axis)))
    spine = sk.path(0, top)
    on_spine = set(spine)
    # ---- arms: per side, the branch off the spine that reaches farthest sideways ------------------------------
    arms = {}
    for j in spine:
        for c in sk.children[j]:
            if c in on_spine or c in leg_joints:
                continue
            sub = sk.subtree(c)
            reach = [float(np.dot(sk.point(s) - pos[j], left_axis)) for s in sub]
            far = int(np.argmax(np.abs(reach)))
            side = "left" if reach[far] > 0 else "right"
            if abs(reach[far]) < 0.1 * height:
                continue
            if side not in arms or abs(reach[far]) > arms[side][0]:
                tip = max(sk.leaves(sub), key=lambda s: np.linalg.norm(sk.point(s) - pos[j]))
                arms[side] = (abs(reach[far]), sk.path(j, tip))
    arm_attach = [chain[0] for _, chain in arms.values()]
    for side, (_, chain) in arms.items():
        parts = _limb(sk, chain, names, ("upperarm", "uparm", "arm", "humerus", "shoulder"))
        for part, body_part in (("before", "collar"), ("upper", "shoulder"), ("lower", "elbow"), ("end", "wrist"),
                                ("next", "hand")):
            if part in parts:
                out[f"{side}_{body_part}"] = names[parts[part]]
    # ---- head: the longest segment above the arms; spine1..neck by height ------------------------------------
    start = max((spine.index(a) for a in arm_attach), default=0)
    pts = [sk.point(s) for s in spine] if spine[-1] not in sk.tips else [pos[s] for s in spine] + [sk.tips[spine[-1]]]
    head_i = None
    best = -1.0
    for i in range(start + 1, len(spine)):
        if not candidate[spine[i]] or i + 1 >= len(pts):
            continue
        length = float(np.linalg.norm(pts[i + 1] - pts[i]))
        if length > best:
            best, head_i = length, i
    if candidate[spine[-1]] and not sk.children[spine[-1]] and spine[-1] not in sk.tips and len(spine) - 1 > start:
        # the top joint is a bone with no end given (a glTF skin's head node): its rotation moves the skull
        head_i = len(spine) - 1
    if head_i is None:
        return out, notes
    out["head"] = names[spine[head_i]]
    inner = [s for s in spine[1:head_i] if candidate[s]]
    J = body.joints()
    bn = list(body.joint_names)
    y0, y1 = J[bn.index("pelvis")][1], J[bn.index("head")][1]
    frac_body = [(J[bn.index(n)][1] - y0) / (y1 - y0) for n in SPINE_BODY]
    ys0, ys1 = pos[0][1], pos[spine[head_i]][1]
    if ys1 - ys0 <= 0:
        return out, notes
    frac_src = [(pos[s][1] - ys0) / (ys1 - ys0) for s in inner]
    for j, i in _spine_assignment(frac_src, frac_body).items():
        out[SPINE_BODY[j]] = names[inner[i]]
    return out, notes
