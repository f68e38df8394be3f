"""Assemble the asset weights dict (docs/asset-format.md, "The weights file") from a garment and the body.

`weights_from_garment(garment, body, network=None)` fills everything that does not come from training: the skeleton
(names, parents, J(β) = J_template + Σ β_b J_shapedirs[b] through the body's J_regressor), the input joints, the
garment (template, shape blend shapes G_S, faces, skin), the clamp ranges and the material defaults. `network` adds the
trained part (the two MLPs, the normalisation statistics, the latent range and the blend shapes D_j).

With `network=None` it makes the LBS-only model: the smallest valid networks whose output is exactly zero (L = 1,
D = 1, one zero layer each, a zero blend shape, x_mean 0, x_std 1, latent range [0, 0]). The runtime then returns the
shaped template skinned by LBS — the demo placeholder and the LBS-only baseline of the evaluation.

    python -m pleat.garment_asset --garment tshirt --out assets/tshirt.pleat
"""
import argparse
import json
import sys
from typing import NamedTuple, Optional

import numpy as np

from pleat.asset import input_count
from pleat.cli import add_quiet, command
# Material (m areal density kg/m², μ N/m, λ N/m, bending k J): the paper's training ranges and HOOD's default, defined
# once in pleat.physics.materials; garment_asset.MATERIAL_* for the callers that read them here.
from pleat.physics.materials import MATERIAL_DEFAULT, MATERIAL_MAX, MATERIAL_MIN  # noqa: F401

# Joints left out of X_c (docs/inputs.md): the pelvis (its motion is the root velocity and tilt), wrists and hands
# (the paper: minimal impact on the garment).
EXCLUDED_INPUT_JOINTS = ("pelvis", "left_wrist", "right_wrist", "left_hand", "right_hand")

BETA_RANGE = (-4.0, 4.0)
DT_RANGE_S = (1.0 / 240.0, 1.0 / 15.0)
LBS_ONLY_MODEL = "lbs-only placeholder, untrained"


def _field(obj, name, default=None):
    if isinstance(obj, dict) or hasattr(obj, "files"):  # dict or np.load(...) of an npz
        return obj[name] if name in obj else default
    return getattr(obj, name, default)


def input_joint_indices(joint_names):
    """Indices of the input joints (all but pelvis, wrists, hands), ascending."""
    names = [str(n) for n in joint_names]
    missing = [n for n in EXCLUDED_INPUT_JOINTS if n not in names]
    if missing:
        raise ValueError(f"body has no joint(s) {missing}; expected SMPL joint names")
    return np.array([k for k, n in enumerate(names) if n not in EXCLUDED_INPUT_JOINTS], dtype=np.int64)


def skeleton_from_body(body):
    """(joint_names, parents, joint_template [J,3], joint_shapedirs [B,J,3]) from the body's J_regressor."""
    regressor = _field(body, "J_regressor")
    v_template = np.asarray(_field(body, "v_template"), dtype=np.float64)
    shapedirs = np.asarray(_field(body, "shapedirs"), dtype=np.float64)  # [V, 3, B]
    joint_template = np.asarray(regressor @ v_template, dtype=np.float64)
    # J is linear in β, so its shape directions are the regressor applied to each body shape direction.
    joint_shapedirs = np.stack([np.asarray(regressor @ shapedirs[:, :, b]) for b in range(shapedirs.shape[2])])
    names = [str(n) for n in _field(body, "joint_names")]
    parents = np.asarray(_field(body, "parents"), dtype=np.int64).copy()
    parents[0] = -1
    return names, parents, joint_template, joint_shapedirs


def lbs_only_network(vertex_count, input_count_without_latent):
    """The smallest valid networks whose output is exactly zero (L = 1, D = 1)."""
    latent_count, blend_count = 1, 1
    input_count = latent_count + input_count_without_latent
    return {
        "x_mean": np.zeros(input_count, np.float32),
        "x_std": np.ones(input_count, np.float32),
        "z_mean": np.zeros(latent_count, np.float32),
        "z_std": np.ones(latent_count, np.float32),
        "z_min": np.zeros(latent_count, np.float32),
        "z_max": np.zeros(latent_count, np.float32),
        "lp.0.weight": np.zeros((latent_count, input_count), np.float32),
        "lp.0.bias": np.zeros(latent_count, np.float32),
        "dec.0.weight": np.zeros((blend_count, latent_count), np.float32),
        "dec.0.bias": np.zeros(blend_count, np.float32),
        "blend_shapes": np.zeros((blend_count, vertex_count, 3), np.float32),
        "lp_activation": "relu",
        "dec_activation": "relu",
    }


def input_count_without_latent(input_joint_count, beta_count):
    """I − L of docs/inputs.md (pleat.asset.input_count without the latent block)."""
    return input_count(0, input_joint_count, beta_count)


# Body anchors (docs/asset-format.md "Body contact"): the body's own skinning at each anchor, truncated to this many
# joints (the body has up to 7 per vertex; the dropped weights are < 2 % there) and renormalised.
BODY_ANCHOR_INFLUENCES = 4
# Garment vertices farther than this from the rest body get no candidates, unless frames showed them meeting the body
# (body_anchors' near_in_motion: a skirt against the legs): a tangent plane 5 cm away says nothing about where the
# body is when the cloth hangs loose, and the full contact's reach ignores planes that far.
BODY_ANCHOR_MAX_DISTANCE_M = 0.05
# Candidate body points per garment vertex (asset 1.2): the rest body vertices nearest to it. The runtime anchors each
# vertex to the blend of its candidates nearest to it in the pose, with the posed body's normal there, so the cloth may
# slide over the body and stay outside. Measured (pleat-eval-suite on sideflip, stealthy_walk1 and punch, the three
# validation clips with the most contact, two bodies, the shipped network; docs/accuracy.md "Body contact"): one point
# per vertex with the turned rest normal (asset 1.1) leaves 1.27 % of vertex-frames inside the body, and more
# candidates do not help while the normal is the turned one; with the posed normal 1 candidate 1.11 %, 4 0.96 %,
# 8 0.91 %. Each candidate costs ~4 ns per vertex and step, the posed normals ~15 ns per point: 4 by default.
# Where simulated frames are at hand, the candidates after the first are chosen from them instead (the body vertices
# most often nearest to the vertex there, pleat.train.contact.candidate_vertices; 16 of them: 0.31 % inside against
# 0.50 % for the 16 rest-nearest and 0.60 % for 4, the same error; docs/accuracy.md "Body contact").
BODY_CONTACT_CANDIDATES = 4
# Body contact per tier, (candidates, posed normals): the full contact costs about what the medium tier's networks
# cost, and a crowd step cannot batch it (it is per instance: docs/benchmarks.md "Body contact"), so only the top tier
# gets it; the cheaper tiers keep the asset 1.1 contact (one point, the turned rest normal, batched in lanes; also
# PLEAT_BODY_CONTACT_FAST), which scenes of many characters can afford (docs/scene-budget.md).
TIER_CONTACT = {"medium": (1, False), "small": (1, False), "xsmall": (1, False)}


def tier_contact(tier):
    """(candidates, posed_normals) for a tier name: "medium", "small", "xsmall" as TIER_CONTACT says; anything else
    ("large", a member, several students averaged as one network, "<n>x<tier>") costs as the top tier, and gets its
    contact."""
    return TIER_CONTACT.get(str(tier or ""), (BODY_CONTACT_CANDIDATES, True))


# Ring points kept per body point (asset 1.2, BARG): the body mesh has at most 8 around a vertex.
BODY_POINT_RING = 8


def _vertex_rings(faces, vertex_count, vertices):
    """The one-ring of each of `vertices` in a mesh whose triangles are counter-clockwise from outside: {v: ring
    [m]}, counter-clockwise, for the closed fans (a vertex on an open edge is left out)."""
    following = {}
    wanted = set(int(v) for v in vertices)
    for a, b, c in np.asarray(faces, np.int64):
        for p, j, k in ((a, b, c), (b, c, a), (c, a, b)):
            if int(p) in wanted:
                following.setdefault(int(p), {})[int(j)] = int(k)
    rings = {}
    for v, nxt in following.items():
        start = next(iter(nxt))
        ring, cur = [start], nxt[start]
        while cur != start and cur in nxt and len(ring) <= len(nxt):
            ring.append(cur)
            cur = nxt[cur]
        if cur == start and len(ring) == len(nxt):
            rings[v] = np.asarray(ring, np.int64)
    return rings


def body_anchors(template, body, influences=BODY_ANCHOR_INFLUENCES, max_distance_m=BODY_ANCHOR_MAX_DISTANCE_M,
                 candidates=BODY_CONTACT_CANDIDATES, posed_normals=True, candidate_vertices=None, collide=None,
                 pinned=None, near_in_motion=None):
    """The body-contact keys of the weights file for a garment template [N, 3] on the mean body: the body points
    (rest body vertices: position, shape directions [B, P, 3], unit normal, and their top `influences` skin joints and
    weights, renormalised; in the order the garment reaches them), per garment vertex its `candidates` nearest points,
    nearest first, and with posed_normals each candidate's ring of body points (asset 1.2). The runtime keeps each
    posed garment vertex outside the blended tangent plane of its candidates nearest to it (pleat.reference.
    body_contact), the simulator's vertex-plane measure. candidates = 1 without posed_normals writes an asset 1.1
    block (one point per vertex, the blended rest normals: the cheapest contact, for the cheapest tiers). collide
    (bool [V], optional): the body vertices the garment collides with (Garment.body_collision_mask); the rest are
    never a candidate. pinned (garment vertex ids, optional): vertices that follow the body by skinning (the pants'
    waistband); the simulator never moves them, so they get no candidates and the runtime's contact leaves them where
    skinning puts them (with candidates, the contact pushed the shipped pants' waistband up to 20 mm off the body).
    near_in_motion (bool [N], with candidate_vertices): the vertices that met the body in the frames the candidates
    came from; they get their candidates however far from the rest body they hang (the dress's skirt: without them
    half its vertices had no contact, and 85 % of what it left inside the legs was theirs)."""
    from scipy.spatial import cKDTree

    from pleat.asset import NO_CANDIDATE
    from pleat.body.model import vertex_normals
    v_template = np.asarray(_field(body, "v_template"), np.float64)
    faces = np.asarray(_field(body, "faces"), np.int64)
    shapedirs = np.asarray(_field(body, "shapedirs"), np.float64)          # [V, 3, B]
    skin = np.asarray(_field(body, "weights"), np.float64)                  # [V, J]
    normals = vertex_normals(v_template, faces)
    C = int(candidates)
    ids = np.arange(len(v_template)) if collide is None else np.flatnonzero(collide)
    distance, nearest = cKDTree(v_template[ids]).query(np.asarray(template, np.float64), k=C)
    distance, nearest = distance.reshape(len(template), C), ids[nearest.reshape(len(template), C)]
    far = distance[:, 0] > max_distance_m                                   # no candidates at all
    rest_far = far.copy()                                   # far from the rest body: no own point (below)
    if candidate_vertices is not None:      # chosen from simulated frames (pleat.train.contact.candidate_vertices)
        given = np.asarray(candidate_vertices, np.int64)
        if given.shape != (len(template), C) or given.min() < -1 or given.max() >= len(v_template):
            raise ValueError(f"candidate_vertices: expected body vertex ids in [0, {len(v_template)}) or -1, "
                             f"shape [{len(template)}, {C}]; got shape {given.shape}")
        if collide is not None:      # a body part the garment passes through is nobody's candidate
            given = np.where((given >= 0) & ~np.asarray(collide, bool)[np.maximum(given, 0)], -1, given)
        if near_in_motion is not None:
            near = np.asarray(near_in_motion)
            if near.shape != (len(template),) or near.dtype != bool:
                raise ValueError(f"near_in_motion: expected bool [{len(template)}], got {near.dtype} {near.shape}")
            far &= ~near
        # each vertex's own row stays its rest-nearest body vertex (the fast contact reads it); a repeat of a
        # candidate would weigh its point twice
        rows = [list(dict.fromkeys(r[r >= 0])) for r in np.concatenate([nearest[:, :1], given[:, 1:]], axis=1)]
        nearest = np.array([r + [-1] * (C - len(r)) for r in rows], np.int64)
    if pinned is not None and len(pinned) > 0:
        far[np.asarray(pinned, np.int64)] = True                            # pinned: skinned, never pushed
    own_usable = ~far & ~rest_far      # a vertex's own point (its row, the fast contact's anchor) is a plane it can use
    valid = nearest >= 0                                                    # -1: an empty slot
    ring_table = None
    if C == 1 and not posed_normals:
        points, table = nearest[:, 0], None                                 # asset 1.1: point i is vertex i's
        point_normals = normals[points]
        point_normals[far] = 0.0
    else:
        # The candidates, then (posed_normals) the rest of their rings, posed with them so that the runtime can take
        # the posed body's own normal at each candidate from the points around it, in the order the garment first
        # reaches them (neighbouring vertices read neighbouring rows).
        def first_seen(values):
            values = np.asarray(values, np.int64).ravel()
            _, first = np.unique(values, return_index=True)
            return values[np.sort(first)]
        # Rows 0..N-1 are the vertices' own nearest body vertices (repeated where two vertices share one), so the
        # fast contact (pleat.h PLEAT_BODY_CONTACT_FAST) reads them as the 1.1 layout; the other candidates and the
        # ring corners follow, once each.
        anchors = first_seen(nearest[~far][valid[~far]])
        rings = _vertex_rings(faces, len(v_template), anchors) if posed_normals else {}
        own = nearest[:, 0]
        rest = first_seen(np.concatenate([anchors] + [rings[v] for v in anchors if v in rings]))
        rest = rest[~np.isin(rest, own[own_usable])]
        points = np.concatenate([own, rest])
        slot = np.full(len(v_template), -1, np.int64)
        slot[rest] = len(own) + np.arange(len(rest))
        slot[own[own_usable][::-1]] = np.flatnonzero(own_usable)[::-1]       # a vertex's own row; shared: the first
        table = np.full((len(template), C), NO_CANDIDATE, np.int64)
        table[~far] = np.where(valid[~far], slot[np.maximum(nearest[~far], 0)], NO_CANDIDATE)
        table[~far, 0] = np.flatnonzero(~far)                               # each vertex's first candidate: its own row
        anchorable = np.zeros(len(points), bool)
        anchorable[np.unique(table[table != NO_CANDIDATE])] = True
        point_normals = normals[points]
        point_normals[~anchorable] = 0.0                                    # far vertices' rows, ring corners
        # a vertex far from the rest body that meets it in motion keeps its own row (the fast contact reads row v)
        # but with no normal: its rest-nearest point is no plane for it, and the fast contact, which pushes in full
        # without the full contact's reach, leaves it alone
        point_normals[np.flatnonzero(~far & rest_far)] = 0.0
        if posed_normals:
            ring_table = np.full((len(points), BODY_POINT_RING), NO_CANDIDATE, np.int64)
            for p in np.flatnonzero(anchorable):
                r = rings.get(int(points[p]))
                if r is not None and 3 <= len(r) <= BODY_POINT_RING:        # else the blended rest normal
                    ring_table[p, :len(r)] = slot[r]
    k = min(influences, skin.shape[1])
    top = np.argsort(-skin[points], axis=1, kind="stable")[:, :k]
    top_weights = np.take_along_axis(skin[points], top, axis=1)
    order = np.argsort(top, axis=1, kind="stable")                          # joints ascending, as the garment skin
    top, top_weights = np.take_along_axis(top, order, axis=1), np.take_along_axis(top_weights, order, axis=1)
    out = {"body_anchor": v_template[points].astype(np.float32),
           "body_anchor_shape": np.ascontiguousarray(shapedirs[points].transpose(2, 0, 1)).astype(np.float32),
           "body_anchor_normal": point_normals.astype(np.float32),
           "body_anchor_skin_indices": top.astype(np.int64),
           "body_anchor_skin_weights": (top_weights / top_weights.sum(axis=1, keepdims=True)).astype(np.float32)}
    if table is not None:
        out["body_anchor_candidates"] = table.astype(np.uint16)
    if ring_table is not None:
        out["body_anchor_ring"] = ring_table.astype(np.uint16)
    return out


class ContactCandidates(NamedTuple):
    """Body-contact candidates chosen from frames (pleat.train.contact): `table` [N, C] body vertex ids (-1: none),
    each vertex's rest-nearest body vertex first; `near` bool [N], the vertices that came within reach of the body
    in some frame (body_anchors' near_in_motion; None: not known); `source`, where the frames came from (META)."""
    table: np.ndarray
    near: Optional[np.ndarray] = None
    source: str = "simulated frames"


def read_candidates(path):
    """A candidates file (pleat-train contact-candidates; pleat-pack --contact-candidates-from) as ContactCandidates
    (a file written before `near_in_motion` and `source` were kept reads None and "simulated frames")."""
    with np.load(path, allow_pickle=False) as z:
        table = np.asarray(z["candidate_vertices"], np.int64)
        near = np.asarray(z["near_in_motion"], bool) if "near_in_motion" in z.files else None
        source = str(z["source"]) if "source" in z.files else "simulated frames"
    return ContactCandidates(table, near, source)


def body_contact_meta(anchors, from_frames=False):
    """The META entry that says how an asset's body anchors were made (from_frames: the candidates were chosen from
    frames, body_anchors(candidate_vertices=…): True for simulated frames, or a string naming where they came
    from)."""
    frames = from_frames if isinstance(from_frames, str) else "simulated frames"
    table = anchors.get("body_anchor_candidates")
    if table is None:
        anchored = int(np.count_nonzero(np.linalg.norm(anchors["body_anchor_normal"], axis=1)))
        return {"anchors": "nearest rest body vertex per garment vertex, its normal and its own top-"
                           f"{anchors['body_anchor_skin_indices'].shape[1]} skin weights",
                "anchored_vertices": anchored, "vertices": int(len(anchors["body_anchor"])),
                "max_distance_m": BODY_ANCHOR_MAX_DISTANCE_M}
    from pleat.asset import NO_CANDIDATE
    rings = anchors.get("body_anchor_ring")
    chosen = (f"the nearest rest body vertex and the {table.shape[1] - 1} body vertices most often nearest in "
              f"{frames}" if from_frames else f"the {table.shape[1]} nearest rest body vertices")
    return {"anchors": f"{chosen} per garment vertex (candidates; the runtime blends those nearest in the pose), "
                       "each with its own top-"
                       f"{anchors['body_anchor_skin_indices'].shape[1]} skin weights and "
                       + ("its ring of body vertices (the posed body's normal)" if rings is not None
                          else "its rest normal (turned by the blended matrix)"),
            "points": int(len(anchors["body_anchor"])), "candidates": int(table.shape[1]),
            "posed_normals": rings is not None, "candidates_from": frames if from_frames else "rest",
            "anchored_vertices": int(np.count_nonzero(table[:, 0] != NO_CANDIDATE)), "vertices": int(len(table)),
            "max_distance_m": BODY_ANCHOR_MAX_DISTANCE_M}


def weights_from_garment(garment, body, network=None, metadata=None, name=None, contact=None, contact_candidates=None):
    """The weights dict pleat-pack / pleat.asset.write_asset reads (docs/asset-format.md key names).

    garment: a pleat.garment Garment, a dict or an npz with template, faces, skin_indices, skin_weights, shape_blend
    [B,N,3] and optionally pinned, name. body: pleat.body.BodyModel (or anything with v_template, shapedirs [V,3,B],
    J_regressor, parents, joint_names). network: None for the LBS-only model, else a dict with the trained keys
    (x_mean, x_std, z_*, lp.i.*, dec.i.*, blend_shapes, lp_activation, dec_activation, optionally train_fps and any
    range override). metadata: extra META JSON fields. contact: (candidates, posed_normals) of the body contact
    (tier_contact; default the top tier's). contact_candidates: body vertex ids [N, C] chosen from simulated frames
    (pleat.train.contact.candidate_vertices) for a full contact (more than one candidate or posed normals); C then
    replaces the contact's count. The 1.1 block (one point, rest normals) ignores them.
    """
    names, parents, joint_template, joint_shapedirs = skeleton_from_body(body)
    input_joints = input_joint_indices(names)
    template = np.asarray(_field(garment, "template"), dtype=np.float32)
    shape_blend = np.asarray(_field(garment, "shape_blend"), dtype=np.float32)
    beta_count = joint_shapedirs.shape[0]
    if shape_blend.shape != (beta_count,) + template.shape:
        raise ValueError(f"garment shape_blend is {shape_blend.shape}, expected {(beta_count,) + template.shape}")
    garment_name = name or _field(garment, "name", None)
    garment_name = str(np.asarray(garment_name)) if garment_name is not None else "garment"

    weights = {
        "garment_name": garment_name,
        "joint_names": names,
        "joint_parents": parents,
        "joint_template": joint_template.astype(np.float32),
        "joint_shapedirs": joint_shapedirs.astype(np.float32),
        "input_joints": input_joints,
        "template": template,
        "shape_blend": shape_blend,
        "faces": np.asarray(_field(garment, "faces"), dtype=np.int64),
        "skin_indices": np.asarray(_field(garment, "skin_indices"), dtype=np.int64),
        "skin_weights": np.asarray(_field(garment, "skin_weights"), dtype=np.float32),
        "dt_range_s": np.array(DT_RANGE_S, np.float32),
        "beta_range": np.array(BETA_RANGE, np.float32),
        "material_min": np.array(MATERIAL_MIN, np.float32),
        "material_max": np.array(MATERIAL_MAX, np.float32),
        "material_default": np.array(MATERIAL_DEFAULT, np.float32),
        "train_fps": np.float32(30.0),
    }
    pinned = _field(garment, "pinned", None)
    if pinned is not None and len(pinned) > 0:
        weights["pinned"] = np.asarray(pinned, dtype=np.int64)
    given = near = None
    if _field(body, "faces") is not None and _field(body, "weights") is not None:   # a body with a surface
        candidates, posed_normals = contact or (BODY_CONTACT_CANDIDATES, True)
        if contact_candidates is not None and (candidates > 1 or posed_normals):
            found = contact_candidates if isinstance(contact_candidates, ContactCandidates) \
                else ContactCandidates(contact_candidates)
            given, near = np.asarray(found.table, np.int64), found.near
            candidates = given.shape[1]
        from pleat.garment.garment import body_collision_mask
        weights.update(body_anchors(template, body, candidates=candidates, posed_normals=posed_normals,
                                    candidate_vertices=given, near_in_motion=near,
                                    collide=body_collision_mask(_field(garment, "collision_exclude", None), body),
                                    pinned=weights.get("pinned")))

    meta = {"garment": garment_name, "vertices": int(template.shape[0]), "faces": int(weights["faces"].shape[0])}
    body_source = _field(body, "source", None)
    if body_source is not None:
        meta["body"] = str(np.asarray(body_source))
    if "body_anchor" in weights:
        meta["body_contact"] = body_contact_meta(weights, from_frames=found.source if given is not None else False)
    excluded = _field(garment, "collision_exclude", None)
    if excluded is not None and len(excluded):
        # by name, so that the evaluation's reference simulation of this asset leaves out the same body parts
        meta["collision_exclude"] = [str(names[int(j)]) for j in np.asarray(excluded).reshape(-1)]
    if network is None:
        weights.update(lbs_only_network(template.shape[0], input_count_without_latent(len(input_joints), beta_count)))
        meta["model"] = LBS_ONLY_MODEL
        meta["note"] = ("Networks output exactly zero: the garment is the shaped template skinned by linear blend "
                        "skinning. Replace with a trained asset (pleat-train pack).")
    else:
        weights.update(network)
    if metadata:
        meta.update(metadata)
    weights["metadata_json"] = json.dumps(meta, sort_keys=True)
    return weights


def _load_garment(spec, vertices, body):
    """A garment from an npz path (pleat-garment output), or generated by pleat.garment from a garment name."""
    import zipfile

    from pleat.cli import InputError, not_npz
    from pleat.garment.generate import GARMENT_NAMES, make_garment
    if spec.endswith(".npz"):
        try:
            with np.load(spec, allow_pickle=False) as data:
                return {k: data[k] for k in data.files}
        except (ValueError, EOFError, zipfile.BadZipFile) as exc:
            raise not_npz(spec, exc, "a garment npz (pleat-garment writes one)") from None
    if spec not in GARMENT_NAMES:
        raise InputError(spec, f"no such garment: not an npz and not one of {', '.join(GARMENT_NAMES)}")
    return make_garment(spec, vertices=vertices or None, body=body)


def build_parser():
    parser = argparse.ArgumentParser(prog="pleat-garment-asset", description=__doc__.split("\n\n")[0])
    parser.add_argument("--garment", required=True, help="garment npz (pleat-garment output) or garment name")
    parser.add_argument("--vertices", type=int, default=0, help="vertex count when generating by name")
    parser.add_argument("--body", default=None, help="body npz (default assets/body.npz)")
    parser.add_argument("--out", required=True, help="output file: the LBS-only .pleat asset")
    parser.add_argument("--name", default=None, help="garment name in the asset (default: the garment's)")
    return add_quiet(parser)


@command("pleat-garment-asset", build_parser)
def main(args):

    from pleat.asset import write_asset
    from pleat.body import BodyModel
    body = BodyModel.load(args.body)
    garment = _load_garment(args.garment, args.vertices, body)
    weights = weights_from_garment(garment, body, None, name=args.name)
    write_asset(args.out, weights)
    print(f"wrote {args.out}: {weights['template'].shape[0]} vertices, LBS-only ({LBS_ONLY_MODEL})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
