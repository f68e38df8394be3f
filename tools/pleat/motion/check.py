"""Is a retargeted clip the source's motion on the body? Two measures that names cannot fool (docs/motion.md,
"The retargeting report").

**Bone directions.** Each body bone that a joint's rotation aims (BONE_CHILD in pleat.motion.retarget: along the
spine, neck, arms and legs — not the pelvis's bones to the hips or the chest's to the clavicles, which are fixed
offsets whose angles only say how the two skeletons' proportions differ) is paired with the source bone that lies
where it lies, by geometry alone. The source's rest skeleton is turned to face +Z and scaled by the leg-length ratio;
the body bone takes the source chain (a joint and a descendant up to three joints down) whose two ends are nearest
its two ends, kept only when the ends together are within half the bone's length. Where the body bone is looked for
depends on the bone:
- the trunk, legs and clavicles: where the body's own rest holds them (pelvis on the source's root). Every source
  holds them about so, and no joint match can move them there;
- the upper arms, forearms and hands: where the body stands when posed in the source's rest by the match under test
  (the retarget of an all-identity source frame), since a source may hold its arms out (T), in an A or down.
Then, over the rest frame and up to 60 frames of the clip, the angle between the body bone's world direction and its
source bone's is measured; a bone's value is its 90th percentile, and the clip's is the worst bone's. A right match
gives ~0° (the rest offsets make the bones agree, and the motion copies world rotations). Body bones with no source
bone in their place (a skeleton without clavicles, a DeepMimic chest) are not measured and are listed as such.

A wrong match cannot hide behind names. With Biovision's names read through the Mixamo table, the body's clavicle
takes the upper arm's rotation, and its rest offset aims the clavicle and upper arm together (the nearest mapped
joint down the chain is the elbow) at the source's upper arm. From a T- or A-pose rest the clavicle bone still lies
on the source's clavicle and is tilted by that offset and swung by every arm movement: 26°. From a rest with the
arms hanging down the offset swings the whole arm down from the collar joint, so in that pose no arm bone of the body
lies on a source bone: looked for there, every arm bone would go unmeasured and the clip would read 0.0° (spine
and legs only). Looked for where the body's own rest holds it, the clavicle is paired with the source's clavicle
whatever the match does, and the wrong match reads 61°.

**Forearms and hands inside the body.** The clip is skinned on the mean body for up to 40 evenly spaced frames, and
128 probes spread evenly over both forearms and hands (vertices whose largest skin weight is an elbow, wrist or hand)
are tested against the posed body without its arms (pleat.motion.inside): a probe is inside when its generalized
winding number with respect to that closed surface is above 1/2 and it is more than INSIDE_DEPTH_M = 2 cm from it.
Winding numbers need no normals, so armpits and crotch are no longer misread, and the depth margin lets a hand rest on
a hip or thigh (which skinning sinks in by a centimetre or so). The clip's value is the largest fraction of probes
inside in any sampled frame.

**Limits: what the training clips do.** Measured on the 31 shipped DeepMimic clips (`pleat-motion limits` prints
both numbers per clip): their bone directions agree to 0.0° (every bone their skeleton has is
aligned). Forearms and hands inside the body: 0 % for 17 of them, walks up to 5.5 %, and TRAINING_INSIDE = 39 % at
most (spin, an arm across the belly; then sideflip 17 %, backflip 15 %, punch 11 % with a fist on the hip,
getup_faceup 10 %, roll 9 %: hands on shins and hips that the wider Pleat body swallows). INSIDE_LIMIT = 1.5 × that
worst clip (59 %). The Biovision-through-Mixamo match above, from a source whose rest pose holds the arms down, puts
the collar on the upper arm's rotation and the forearms through the chest: 95 % (the same source matched right: 0 %),
and its clavicles are 61° off. From a T- or A-pose source the same wrong match keeps the forearms out of the body
(0 %), and BONE_LIMIT_DEG = 10° catches it (26°). The six naming schemes of the tests matched right score 0 % and
under 1° in all three rest poses.
"""
import sys
from dataclasses import dataclass, field

import numpy as np

from pleat.motion.readers import MotionFileError, strict_from_environment

BONE_LIMIT_DEG = 10.0
TRAINING_INSIDE = 0.391        # measured: the largest fraction over the 31 shipped clips (see the module doc)
INSIDE_LIMIT = max(1.5 * TRAINING_INSIDE, 0.02)
INSIDE_DEPTH_M = 0.02
MAX_BONE_FRAMES = 60
MAX_SKIN_FRAMES = 40
ARM_BELOW_SHOULDER = ("_shoulder", "_elbow", "_wrist")   # bones from these joints: placed by the pose
MATCH_TOLERANCE = 0.5          # the two ends of a body bone within half its length of the source bone's ends


@dataclass
class RetargetCheck:
    """The two measures of one clip (see the module doc)."""
    bone_deg: dict = field(default_factory=dict)        # body bone "parent→joint" → 90th percentile angle (deg)
    bone_rest_deg: dict = field(default_factory=dict)   # the same in the rest frame alone
    bone_source: dict = field(default_factory=dict)     # body bone → "source joint→source joint"
    unmeasured: list = field(default_factory=list)      # body bones with no source bone in their place
    inside_fraction: float = 0.0                       # largest fraction of forearm/hand probes inside the body
    inside_frame: int = 0                              # the clip frame where it is largest
    worst_bone_frame: int = 0                          # the clip frame where the worst bone is farthest off

    @property
    def worst_bone(self):
        if not self.bone_deg:
            return None, 0.0
        k = max(self.bone_deg, key=self.bone_deg.get)
        return k, self.bone_deg[k]

    @property
    def problems(self):
        """One phrase per limit the clip goes beyond (empty when it is within what the training clips do)."""
        out = []
        bone, deg = self.worst_bone
        if deg > BONE_LIMIT_DEG:
            bad = sorted((k for k, v in self.bone_deg.items() if v > BONE_LIMIT_DEG), key=lambda k: -self.bone_deg[k])
            out.append(f"bone directions up to {deg:.0f}° off the source's (limit {BONE_LIMIT_DEG:.0f}°: "
                       + ", ".join(f"{k} {self.bone_deg[k]:.0f}°" for k in bad[:3]) + ")")
        if self.inside_fraction > INSIDE_LIMIT:
            out.append(f"{100 * self.inside_fraction:.1f} % of the forearms and hands inside the body at frame "
                       f"{self.inside_frame} (limit {100 * INSIDE_LIMIT:.0f} %)")
        return out

    def lines(self):
        """The report `pleat-motion joints` prints under the joint table."""
        out = ["  bone directions, body vs source (90th percentile over the clip; rest pose in brackets):"]
        for k in sorted(self.bone_deg, key=lambda k: -self.bone_deg[k]):
            flag = "  <-- over the limit" if self.bone_deg[k] > BONE_LIMIT_DEG else ""
            out.append(f"    {k:28s} {self.bone_deg[k]:5.1f}° ({self.bone_rest_deg[k]:4.1f}°)  on "
                       f"{self.bone_source[k]}{flag}")
        if self.unmeasured:
            out.append("    not measured (no source bone in that place): " + ", ".join(self.unmeasured))
        bone, deg = self.worst_bone
        out.append(f"  worst bone: {bone or '-'} {deg:.1f}° (limit {BONE_LIMIT_DEG:.0f}°); forearms and hands "
                   f"inside the body: {100 * self.inside_fraction:.1f} % of them at worst (frame "
                   f"{self.inside_frame}; limit {100 * INSIDE_LIMIT:.0f} %)")
        problems = self.problems
        out.append("  check: " + ("; ".join(problems) if problems else "within what the training clips do"))
        return out

    def as_dict(self):
        bone, deg = self.worst_bone
        return dict(worst_bone=bone, worst_bone_deg=round(deg, 2), bone_deg={k: round(v, 2) for k, v in
                                                                              self.bone_deg.items()},
                    bone_source=dict(self.bone_source), unmeasured=list(self.unmeasured),
                    inside_fraction=round(self.inside_fraction, 4), inside_frame=self.inside_frame,
                    problems=self.problems)


def _frames(n, most):
    return np.unique(np.linspace(0, n - 1, min(most, n)).astype(np.int64))


def _angle_deg(a, b):
    na, nb = np.linalg.norm(a, axis=-1), np.linalg.norm(b, axis=-1)
    cos = np.sum(a * b, axis=-1) / np.maximum(na * nb, 1e-12)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def bone_directions(src, mapping, clip, body, spread=None, rest_offsets="limbs"):
    """The bone-direction measure (module doc) → (bone_deg, bone_rest_deg, bone_source, unmeasured, worst frame)."""
    from dataclasses import replace as dc_replace
    from pleat.motion.retarget import BONE_CHILD, retarget, source_facing, source_leg_scale
    names = list(body.joint_names)
    S = len(src.names)
    still = np.broadcast_to(np.eye(3), (2, S, 3, 3)).copy()
    rest_src = dc_replace(src, local_rotations=still, root_positions=np.zeros((2, 3)) + src.rest_positions[0])
    posed_rest = retarget(rest_src, mapping, body, spread=spread, root_scale=1.0, ground=False,
                          rest_offsets=rest_offsets)
    Jb = posed_rest.joint_positions(body)[0]
    Jb = Jb - Jb[0]
    # where each bone is looked for: the trunk, legs and clavicles where the body's own rest holds them (every source
    # holds them about so, and no joint match can move them there), the arm below the shoulder where the match under
    # test poses it (the source may hold its arms out, in an A or down)
    Jown = body.joints() - body.joints()[0]
    place = {k: Jb if names[int(body.parents[k])].endswith(ARM_BELOW_SHOULDER) else Jown for k in range(len(names))}
    C = source_facing(src, mapping)
    scale = source_leg_scale(src, mapping, body)
    rest = np.asarray(src.rest_positions, np.float64)
    Ps = (rest - rest[0]) @ C.T * scale
    # source chains: a joint and a descendant up to three joints down, of non-zero length
    chains = []
    for b in range(1, S):
        a, hops = int(src.parents[b]), 1
        while a >= 0 and hops <= 3:
            if np.linalg.norm(Ps[b] - Ps[a]) > 1e-6:
                chains.append((a, b))
            a, hops = int(src.parents[a]), hops + 1
    chains = np.array(chains, np.int64).reshape(-1, 2)
    pairs, unmeasured = {}, []
    for k in range(1, len(names)):
        p = int(body.parents[k])
        J = place[k]
        length = np.linalg.norm(J[k] - J[p])
        label = f"{names[p]}→{names[k]}"
        if length < 0.01 or not len(chains) or BONE_CHILD.get(names[p]) != names[k]:
            continue
        cost = (np.linalg.norm(Ps[chains[:, 0]] - J[p], axis=1) + np.linalg.norm(Ps[chains[:, 1]] - J[k], axis=1))
        i = int(np.argmin(cost))
        if cost[i] <= MATCH_TOLERANCE * length:
            pairs[label] = (p, k, int(chains[i, 0]), int(chains[i, 1]))
        else:
            unmeasured.append(label)
    frames = _frames(clip.num_frames, MAX_BONE_FRAMES)
    Jt = clip.joint_positions(body)[frames]
    Pt = src.world_positions()[frames] @ C.T
    deg, rest_deg, where, worst_frame, worst = {}, {}, {}, 0, -1.0
    for label, (p, k, a, b) in pairs.items():
        rest_angle = float(_angle_deg(Jb[k] - Jb[p], Ps[b] - Ps[a]))
        angles = _angle_deg(Jt[:, k] - Jt[:, p], Pt[:, b] - Pt[:, a])
        deg[label] = float(np.percentile(np.concatenate([[rest_angle], angles]), 90))
        rest_deg[label] = rest_angle
        where[label] = f"{src.names[a]}→{src.names[b]}"
        if angles.max() > worst:
            worst, worst_frame = float(angles.max()), int(frames[int(np.argmax(angles))])
    return deg, rest_deg, where, unmeasured, worst_frame


_SURFACES = {}


def limbs_inside_body(clip, body, beta=None):
    """The self-intersection measure (module doc) → (largest fraction of probes inside, clip frame)."""
    from pleat.motion.inside import ArmlessSurface, probes_inside
    from pleat.rotations import quat_to_matrix
    key = id(body)
    if key not in _SURFACES or _SURFACES[key][0] is not body:
        _SURFACES[key] = (body, ArmlessSurface(body))
    surface = _SURFACES[key][1]
    frames = _frames(clip.num_frames, MAX_SKIN_FRAMES)
    G = body.forward_kinematics(quat_to_matrix(clip.local_rotations[frames]), clip.root_translation[frames],
                                quat_to_matrix(clip.root_rotation[frames]), beta)
    M = body.skinning_matrices(G, beta)[..., :3, :]
    share = probes_inside(body, surface, M, body.shaped_vertices(beta), INSIDE_DEPTH_M).mean(axis=1)
    i = int(np.argmax(share))
    return float(share[i]), int(frames[i])


def check_retarget(src, mapping, clip, body, spread=None, rest_offsets="limbs"):
    """Both measures for a clip retargeted from `src` with `mapping` → RetargetCheck. src None (a Pleat clip npz,
    already on the body): the self-intersection alone."""
    out = RetargetCheck()
    if src is not None:
        (out.bone_deg, out.bone_rest_deg, out.bone_source, out.unmeasured,
         out.worst_bone_frame) = bone_directions(src, mapping, clip, body, spread, rest_offsets)
    out.inside_fraction, out.inside_frame = limbs_inside_body(clip, body)
    return out


def report(check, path, strict=False, warn=None):
    """A clip beyond the limits: one warning line (`warn`, default stderr), or with `strict` a MotionFileError."""
    problems = check.problems
    if not problems:
        return
    if strict is None:
        strict = strict_from_environment()
    text = "; ".join(problems) + " — check the joint match with pleat-motion joints"
    if strict:
        raise MotionFileError(path, "retargeting check failed (--strict): " + text)
    (warn or (lambda m: print(m, file=sys.stderr)))(f"warning: {path}: {text}")


def write_preview(out, clip, body, check, src=None, mapping=None):
    """A PNG for the report: the body in the source's rest pose, and at the frames where the worst bone and the
    deepest forearm are; titles carry the numbers."""
    from pleat.draw import BODY_COLOR, contact_sheet
    frames = sorted({0, check.worst_bone_frame, check.inside_frame, clip.num_frames // 2})
    v = clip.skin(body, frames=np.array(frames))
    panels, titles = [], []
    for i, t in enumerate(frames):
        panels.append([(v[i], body.faces, BODY_COLOR)])
        tag = []
        if t == check.worst_bone_frame and check.bone_deg:
            tag.append(f"worst bone {check.worst_bone[1]:.0f}°")
        if t == check.inside_frame and check.inside_fraction > 0:
            tag.append(f"{100 * check.inside_fraction:.0f}% inside")
        titles.append(f"frame {t}" + (": " + ", ".join(tag) if tag else ""))
    contact_sheet(panels, out, titles)
