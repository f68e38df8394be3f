"""Garment regions: the parts of a garment where skinning fails, to be scored on their own (docs/accuracy.md,
"Regions").

A garment-wide mean hides the few places where cloth leaves the body — a skirt, a crotch, the cloth around a bent
knee or elbow, a loose cuff or armhole. Each region here is placed from the body's rest joints J(0) and the mesh's
boundary loops (its openings), the same landmarks the procedural garments are cut from (pleat.garment.generate),
so a region means the same part of the garment at any vertex count (tested at 300–4,400 vertices).

    garment_regions("dress", template, faces, body)  ->  {"all": ..., "skirt": ..., "bodice": ...}

The template is the rest garment on the β = 0 body (metres, +Y up, facing +Z). Every garment gets "all"; a name the
table below does not know (a user's own garment) gets only "all".

| garment     | regions |
|-------------|---------|
| dress       | skirt (below 2 cm above the hip joints' mean height: where the generator starts the skirt), bodice |
| pants       | waistband (within 5 cm of the top opening), crotch, knees |
| long_sleeve | elbows, cuffs |
| tank_top    | armholes |
| tshirt      | sleeves (dominant skin joint a shoulder or elbow), torso |
"""
import numpy as np

from pleat.garment import mesh as M

# Distances in metres. The generated garments' edges are 1.5–6.5 cm long between 4,400 and 300 vertices, so a band
# of a few centimetres holds at least the opening's own vertices and, at the finer counts, a few rings beside them.
SKIRT_ABOVE_HIPS_M = 0.02        # the generator's skirt starts at the hip joints' mean height + 2 cm
WAISTBAND_M = 0.05               # from the pants' top opening
CROTCH_HALF_WIDTH_M = 0.08       # from the body's mid-sagittal plane (the hip joints are ~11.5 cm out)
KNEE_RADIUS_M = 0.10
ELBOW_RADIUS_M = 0.08
CUFF_M = 0.05
ARMHOLE_M = 0.04
SLEEVE_JOINTS = ("left_shoulder", "right_shoulder", "left_elbow", "right_elbow")
# An opening farther than this from the joint it is looked for at is not that opening (a user's mesh under a known
# name, cut differently): the region is then left empty rather than placed somewhere meaningless.
OPENING_SEARCH_M = 0.30

REGION_NAMES = {
    "dress": ("skirt", "bodice"),
    "pants": ("waistband", "crotch", "knees"),
    "long_sleeve": ("elbows", "cuffs"),
    "tank_top": ("armholes",),
    "tshirt": ("sleeves", "torso"),
}


def distance_to_loop(points, loop_points):
    """Distance [P] from each point to a closed polyline (the opening, not just its vertices: at coarse counts an
    opening's vertices are several centimetres apart)."""
    p = np.asarray(points, np.float64)
    a = np.asarray(loop_points, np.float64)
    b = np.roll(a, -1, axis=0)
    ab = b - a                                                         # [L, 3]
    denom = np.maximum(np.einsum("lc,lc->l", ab, ab), 1e-18)
    t = np.clip(np.einsum("plc,lc->pl", p[:, None, :] - a[None], ab) / denom, 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]                        # [P, L, 3]
    return np.linalg.norm(p[:, None, :] - closest, axis=-1).min(axis=1)


def _opening_near(x, loops, point):
    """The boundary loop whose centroid is nearest `point`, or None when none is within OPENING_SEARCH_M."""
    if not loops:
        return None
    d = [np.linalg.norm(x[L].mean(axis=0) - point) for L in loops]
    k = int(np.argmin(d))
    return loops[k] if d[k] <= OPENING_SEARCH_M else None


def _near_openings(x, loops, points, band_m):
    """Vertices within band_m of the openings nearest each of `points` (one opening per point)."""
    out = np.zeros(len(x), bool)
    for point in points:
        loop = _opening_near(x, loops, point)
        if loop is not None:
            out |= distance_to_loop(x, x[loop]) <= band_m
    return out


def _near_joints(x, joints):
    return np.min([np.linalg.norm(x - j, axis=1) for j in joints], axis=0)


def _dominant_joints(x, faces, body, skin_indices, skin_weights):
    if skin_indices is None or skin_weights is None:
        # the generator's own diffusion (its shape check changes only the shape blend shapes, not the skin)
        from pleat.garment.generate import diffuse_from_body
        skin_indices, skin_weights, _ = diffuse_from_body(x, faces, body, beta_check=0)
    si = np.asarray(skin_indices)
    return si[np.arange(len(si)), np.argmax(np.asarray(skin_weights), axis=1)]


def garment_regions(garment_name, template, faces, body, skin_indices=None, skin_weights=None):
    """dict region name → bool [N] for garment `garment_name` (REGION_NAMES; "all" for every garment).

    template [N, 3] rest garment on the β = 0 body, faces [F, 3], body a pleat.body.BodyModel (its rest joints J(0)
    place the regions). skin_indices / skin_weights [N, K] (optional, the tshirt's sleeves): the garment's skin; when
    absent it is diffused from the body as the generator does."""
    x = np.asarray(template, np.float64)
    f = np.asarray(faces, np.int64)
    n = len(x)
    regions = {"all": np.ones(n, bool)}
    name = str(garment_name)
    if name not in REGION_NAMES or n == 0:
        return regions
    names = list(body.joint_names)
    J = body.joints()

    def joint(k):
        return J[names.index(k)]

    loops = M.boundary_loops(f)
    hip_y = 0.5 * (joint("left_hip")[1] + joint("right_hip")[1])
    if name == "dress":
        skirt = x[:, 1] < hip_y + SKIRT_ABOVE_HIPS_M
        regions.update(skirt=skirt, bodice=~skirt)
    elif name == "pants":
        top = max(loops, key=lambda L: x[L, 1].mean()) if loops else None
        regions["waistband"] = (np.zeros(n, bool) if top is None
                                else distance_to_loop(x, x[top]) <= WAISTBAND_M)
        knee_y = 0.5 * (joint("left_knee")[1] + joint("right_knee")[1])
        mid_x = 0.5 * (joint("left_hip")[0] + joint("right_hip")[0])
        regions["crotch"] = ((x[:, 1] < hip_y) & (x[:, 1] > 0.5 * (hip_y + knee_y))
                             & (np.abs(x[:, 0] - mid_x) <= CROTCH_HALF_WIDTH_M))
        regions["knees"] = _near_joints(x, [joint("left_knee"), joint("right_knee")]) <= KNEE_RADIUS_M
    elif name == "long_sleeve":
        regions["elbows"] = _near_joints(x, [joint("left_elbow"), joint("right_elbow")]) <= ELBOW_RADIUS_M
        regions["cuffs"] = _near_openings(x, loops, [joint("left_wrist"), joint("right_wrist")], CUFF_M)
    elif name == "tank_top":
        regions["armholes"] = _near_openings(x, loops, [joint("left_shoulder"), joint("right_shoulder")], ARMHOLE_M)
    elif name == "tshirt":
        dominant = _dominant_joints(x, f, body, skin_indices, skin_weights)
        sleeves = np.isin(dominant, [names.index(k) for k in SLEEVE_JOINTS])
        regions.update(sleeves=sleeves, torso=~sleeves)
    return regions
