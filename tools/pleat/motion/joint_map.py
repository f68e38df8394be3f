"""Which source joint drives which body joint (docs/motion.md, "Your own skeleton").

For a BVH or ASF/AMC skeleton, each body joint (SMPL-style names: pelvis, left_hip, ...) gets a source joint by, in
this order:
1. a joint-map file (`--joint-map FILE`): JSON {source joint name: body joint name, or null to leave it unused};
2. the Mixamo table (`MIXAMO_TO_BODY`), on names with their namespace stripped (`mixamorig:LeftUpLeg` → LeftUpLeg);
3. common naming schemes (CMU BVH, Biovision, Acclaim/CMU ASF), on the stripped names.
The body's pelvis is always the source root. Legs (hips, knees, ankles) are required: without them there is no
facing, no scale and no ground, and the loader says which are missing. Any other body joint without a source joint
moves rigidly with its parent. `JointMatch` records the result for the report that `pleat-motion joints` prints.
"""
import json
from dataclasses import dataclass, field
from pathlib import Path

from pleat.body.model import SMPL_JOINT_NAMES
from pleat.cli import InputError
from pleat.motion.names import (MIXAMO_TO_BODY, guess_joint_map,  # noqa: F401  (importers find them here)
                                strip_namespace)

REQUIRED_JOINTS = ("pelvis", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle")


def read_joint_map_file(path, body_names=SMPL_JOINT_NAMES):
    """A --joint-map JSON file → {source name: body name or None}, checked: an object whose values are body joint
    names (or null) and that gives no body joint twice."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(path, "joint map file not found") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(path, f"joint map is not valid JSON ({exc})") from None
    if not isinstance(data, dict) or not data:
        raise InputError(path, 'joint map must be a JSON object {"source joint": "body joint", ...}')
    known = set(body_names)
    seen = {}
    for src, dst in data.items():
        if dst is None:
            continue
        if not isinstance(dst, str) or dst not in known:
            raise InputError(path, f"joint map entry {src!r}: {dst!r} is not a body joint "
                                   f"(one of {', '.join(body_names)}, or null)")
        if dst in seen:
            raise InputError(path, f"joint map gives body joint {dst!r} twice ({seen[dst]!r} and {src!r})")
        seen[dst] = src
    return dict(data)


@dataclass
class JointMatch:
    """The body joint → source joint map used by retargeting, and where each entry came from."""
    mapping: dict                       # body joint → source joint name (as in the file)
    origin: dict                        # body joint → "joint map" | "Mixamo table" | "name guess" | "fixed"
    source_names: list
    body_names: tuple = SMPL_JOINT_NAMES
    source_animated: list = field(default=None)   # source joints with rotation channels (None: all)
    shared: dict = field(default_factory=dict)    # body joint → source joint whose rotation it shares (spread)
    notes: dict = field(default_factory=dict)     # how the structure told the sides apart (pleat.motion.structure)

    @property
    def unmatched(self):
        return [n for n in self.body_names if n not in self.mapping and n not in self.shared]

    @property
    def unused(self):
        used = set(self.mapping.values())
        pool = self.source_animated if self.source_animated is not None else self.source_names
        return [n for n in pool if n not in used]

    @property
    def missing_required(self):
        return [n for n in REQUIRED_JOINTS if n not in self.mapping]

    def as_dict(self):
        return dict(matched={k: self.mapping[k] for k in self.body_names if k in self.mapping},
                    shared=dict(self.shared), unmatched=self.unmatched, unused=self.unused)

    def lines(self):
        """The report: one line per body joint, then the source joints no body joint uses."""
        out = []
        for k in self.body_names:
            if k in self.shared:
                out.append(f"  {k:15s} <- a share of {self.shared[k]}'s rotation  (spread over a chain)")
            elif k in self.mapping:
                out.append(f"  {k:15s} <- {self.mapping[k]}  ({self.origin[k]})")
            else:
                out.append(f"  {k:15s} -- unmatched: moves with its parent")
        out.append(f"  {len(self.mapping) + len(self.shared)} of {len(self.body_names)} body joints matched; "
                   "source joints unused: "
                   + (", ".join(self.unused) if self.unused else "none"))
        return out


def _name_tables(names, taken, body_names):
    """Body joint → (source joint, table) from the names alone: the body's own names, the Mixamo table, then the
    guesses (CMU BVH, Biovision, Acclaim ASF)."""
    out, used = {}, set(taken)
    for raw in names:
        s = strip_namespace(raw)
        if s in body_names and s != "pelvis" and raw not in used and s not in out:
            out[s] = (raw, "body names")
            used.add(raw)
    for raw in names:
        dst = MIXAMO_TO_BODY.get(strip_namespace(raw))
        if dst and dst != "pelvis" and dst not in out and raw not in used and dst in body_names:
            out[dst] = (raw, "Mixamo table")
            used.add(raw)
    for dst, raw in guess_joint_map([n for n in names if n not in used], root=False).items():
        if dst != "pelvis" and dst not in out and dst in body_names:
            out[dst] = (raw, "name guess")
    return out


def match_joints(source_names, user_map=None, map_path=None, body_names=SMPL_JOINT_NAMES, source_animated=None,
                 parents=None, rest=None, body=None, tips=None, candidate=None):
    """source_names (root first) → JointMatch. user_map: {source name: body name or None} (read_joint_map_file);
    its source names may be given with or without their namespace. With the rest skeleton (parents, rest
    positions, the body), joints are matched by structure (pleat.motion.structure) and names only label (or, where
    the structure finds nothing, fill) the match; without it, by names alone."""
    names = list(source_names)
    by_stripped = {}
    for n in names:
        by_stripped.setdefault(strip_namespace(n), n)
    mapping, origin, taken = {}, {}, set()
    notes = {}

    root = names[0] if names else None
    if user_map:
        for src, dst in user_map.items():
            raw = src if src in names else by_stripped.get(strip_namespace(src))
            if raw is None:
                raise InputError(map_path, f"joint map names {src!r}, which the skeleton does not have")
            if (dst == "pelvis" and raw != root) or (dst not in (None, "pelvis") and raw == root):
                raise InputError(map_path, f"the body's pelvis must be the skeleton's root {root!r} "
                                           f"(the joint map pairs {src!r} with {dst!r})")
            taken.add(raw)
            if dst is not None:
                mapping[dst] = raw
                origin[dst] = "joint map"
    if root is not None:
        mapping["pelvis"] = root
        origin.setdefault("pelvis", "root")
        taken.add(root)
    by_name = _name_tables(names, taken, body_names)
    if rest is not None and parents is not None and body is not None and len(names) > 1:
        from pleat.motion.structure import structure_map
        found, notes = structure_map(names, parents, rest, body, candidate, tips)
        for dst, raw in found.items():
            if dst == "pelvis" or dst in mapping or raw in taken or dst not in body_names:
                continue
            mapping[dst] = raw
            named = by_name.get(dst)
            if named and named[0] == raw:
                origin[dst] = f"structure; {named[1]} agrees"
            elif named:
                origin[dst] = f"structure; the names say {named[0]}"
            else:
                origin[dst] = "structure"
            taken.add(raw)
    for dst, (raw, table) in by_name.items():
        if dst not in mapping and raw not in taken:
            mapping[dst] = raw
            origin[dst] = table
            taken.add(raw)
    return JointMatch(mapping=mapping, origin=origin, source_names=names, body_names=tuple(body_names),
                      source_animated=source_animated, notes=notes)
