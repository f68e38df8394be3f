"""Would canonical spine inputs help on motion from another source? (docs/probes.md, "Motion from a skeleton unlike
the training data's"; not a test, a probe.) All training motion spreads the chest's rotation evenly over spine1..3; a
source with a real spine does not. Per clip: the clip re-expressed with the 0.5 / 0.3 / 0.2 split
(bench/reexpress_clips.py), the reference simulated on it, and the shipped t-shirt through the Python reference
twice: as the runtime runs it, and with the networks fed the even split of the same chest rotation while skinning
(and the body contact) use the real pose. Mean vertex error (mm, 60 frames, beta = 0) of both and of LBS-only.

    PYTHONPATH=tools .venv/bin/python bench/canonical_spine_probe.py deepmimic_github/humanoid3d_jog ...
"""
import importlib
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reexpress_clips import _quat_power, reexpress  # noqa: E402

from pleat.body import BodyModel
from pleat.eval import scene as S
from pleat.eval.reference import cached_simulate
from pleat.eval.scene import clip_rotations_for
from pleat.motion.loaders import load_clip_at
from pleat.rotations import quat_multiply
ri = importlib.import_module("pleat.reference.instance")   # the module (the package exports its class)


def even_spine(clip):
    names = list(clip.joint_names)
    q = clip.local_rotations.copy()
    s = [names.index(n) for n in ("spine1", "spine2", "spine3")]
    total = quat_multiply(quat_multiply(q[:, s[0]], q[:, s[1]]), q[:, s[2]])
    for k in s:
        q[:, k] = _quat_power(total, 1.0 / 3.0)
    return replace(clip, local_rotations=q)


def run(weights, clip_inputs, clip_skin):
    """Positions of the Python reference instance whose networks see clip_inputs and whose skinning sees clip_skin
    (the two instances step in lockstep; the second deforms with the first's skinning matrices)."""
    inst_skin, inst = ri.Instance(weights), ri.Instance(weights)
    rot_i = clip_rotations_for(clip_inputs, weights["joint_names"])
    rot_s = clip_rotations_for(clip_skin, weights["joint_names"])
    captured = {}
    orig_skin = inst_skin._deform
    def cap(bw, M):
        captured["M"] = M
        return orig_skin(bw, M)
    inst_skin._deform = cap
    orig = inst._deform
    inst._deform = lambda bw, M: orig(bw, captured["M"])
    out = []
    for t in range(len(rot_i)):
        inst_skin.step(rot_s[t], clip_skin.root_translation[t], clip_skin.root_rotation[t], 1 / 30)
        p, _ = inst.step(rot_i[t], clip_inputs.root_translation[t], clip_inputs.root_rotation[t], 1 / 30)
        out.append(p)
    return np.array(out)


_, weights = S.read_weights("assets/tshirt.pleat")
lbs_w = S.lbs_only_weights(weights)
body = BodyModel.load(None)
garment = S.garment_from_asset(weights)
beta = np.zeros(len(weights["shape_blend"]), np.float32)
material = np.asarray(weights["material_default"], np.float32)
rows = []
for name in sys.argv[1:]:
    orig = load_clip_at(name, fps=30.0, max_frames=60)
    path = Path("out/canon") / (Path(name).name + "_spine.npz")
    reexpress(orig, True, 0.0).save(path)
    clip = S.load_motion(str(path), body, 30.0, 60)
    canon = even_spine(clip)
    T = clip.num_frames
    ref, _ = cached_simulate(garment, body, clip, beta, material, T, cache_dir="out/canon/cache", progress=False)
    ref = np.asarray(ref)

    def err(p):
        return float(np.mean(np.linalg.norm(p - ref[:len(p)], axis=-1)) * 1000)
    raw, can, lbs = run(weights, clip, clip), run(weights, canon, clip), run(lbs_w, clip, clip)
    rows.append((err(raw), err(can), err(lbs)))
    print(f"{name}: raw {rows[-1][0]:.2f} mm, canonical inputs {rows[-1][1]:.2f}, LBS {rows[-1][2]:.2f}; ratios {rows[-1][0]/rows[-1][2]:.3f} / {rows[-1][1]/rows[-1][2]:.3f}", flush=True)
r = np.array(rows).mean(0)
print(f"mean: raw {r[0]:.2f}, canonical {r[1]:.2f}, LBS {r[2]:.2f}; ratios {r[0]/r[2]:.3f} / {r[1]/r[2]:.3f}")
