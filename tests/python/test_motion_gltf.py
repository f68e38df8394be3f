"""glTF / GLB animations as a motion source (pleat.motion.gltf): a walk written as a Mixamo-named BVH and as a glTF of
the same skeleton — with rest node rotations that are not identity, an armature node above the root that turns and
scales, and the joint translations in centimetres — comes out as the same clip through load_clip; GLB is the same
file; STEP, CUBICSPLINE and the choice of animation; a broken file is one MotionFileError line."""
import base64
import json

import numpy as np
import pytest

pygltflib = pytest.importorskip("pygltflib")

from pleat.motion import MotionFileError, load_clip                     # noqa: E402
from pleat.motion.bvh_export import write_bvh                          # noqa: E402
from pleat.motion.gltf import read_gltf                                 # noqa: E402
from pleat.motion.joint_map import MIXAMO_TO_BODY                       # noqa: E402
from pleat.rotations import matrix_to_quat, quat_to_matrix, yaw_matrix  # noqa: E402

CLIP = "deepmimic_pybullet/humanoid3d_walk"
FRAMES = 24
BODY_TO_MIXAMO = {b: m for m, b in MIXAMO_TO_BODY.items()}
ARMATURE_YAW = 0.7          # rad: the armature node turns the whole skeleton (retargeting faces it forward again)
ARMATURE_SCALE = 0.01       # joint translations in cm under a 0.01-scaled armature, as Blender exports FBX rigs


@pytest.fixture(scope="module")
def walk(body):
    try:
        clip = load_clip(CLIP, body=body).resample(30.0)
    except MotionFileError as exc:
        pytest.skip(f"no motion clips ({exc})")
    from dataclasses import replace
    return replace(clip, local_rotations=clip.local_rotations[:FRAMES], root_translation=clip.root_translation[:FRAMES],
                   root_rotation=clip.root_rotation[:FRAMES])


def _mixamo_bvh(path, clip, body):
    """The clip as a BVH of the body's skeleton with Mixamo joint names (so it is retargeted, not read exactly)."""
    write_bvh(path, clip, body, units="m")
    text = path.read_text()
    for name in sorted(body.joint_names, key=len, reverse=True):
        text = text.replace(f"JOINT {name}\n", f"JOINT {BODY_TO_MIXAMO[name]}\n")
        text = text.replace(f"ROOT {name}\n", f"ROOT {BODY_TO_MIXAMO[name]}\n")
    path.write_text(text)
    return path


def _bvh_world(clip, body):
    """World rotations [T, K, 3, 3] and root joint positions [T, 3] of the BVH write_bvh makes (rest = identity)."""
    R = quat_to_matrix(clip.local_rotations)
    Q = quat_to_matrix(clip.root_rotation)
    W = np.empty_like(R)
    for k, p in enumerate(body.parents):
        W[:, k] = Q @ R[:, 0] if p < 0 else W[:, p] @ R[:, k]
    p0 = clip.root_translation + np.einsum("tij,j->ti", Q, body.joints()[0])
    return W, p0


class _Doc:
    """A glTF document built in memory: accessors appended to one buffer."""

    def __init__(self):
        self.g = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"))
        self.blob = bytearray()

    def accessor(self, values, kind):
        a = np.ascontiguousarray(values, np.float32)
        view = pygltflib.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=a.nbytes)
        self.blob += a.tobytes()
        self.g.bufferViews.append(view)
        self.g.accessors.append(pygltflib.Accessor(bufferView=len(self.g.bufferViews) - 1, componentType=5126,
                                                   count=len(a), type=kind))
        return len(self.g.accessors) - 1

    def animation(self, name, channels):
        """channels: [(node, "rotation" | "translation", times, values, interpolation)]."""
        anim = pygltflib.Animation(name=name)
        for node, what, times, values, interp in channels:
            anim.samplers.append(pygltflib.AnimationSampler(
                input=self.accessor(times, "SCALAR"), output=self.accessor(values, "VEC4" if what == "rotation"
                                                                           else "VEC3"), interpolation=interp))
            anim.channels.append(pygltflib.AnimationChannel(
                sampler=len(anim.samplers) - 1, target=pygltflib.AnimationChannelTarget(node=node, path=what)))
        self.g.animations.append(anim)

    def save(self, path):
        self.g.buffers = [pygltflib.Buffer(byteLength=len(self.blob), uri="data:application/octet-stream;base64,"
                                           + base64.b64encode(bytes(self.blob)).decode())]
        self.g.save(str(path))
        return path


def _walk_document(clip, body, seed=0):
    """(doc, joint node indices, per-frame local rotations [T, K, 4], root translations [T, 3] in armature units):
    the walk on a skeleton whose rest pose has random node rotations. Node 0 is the armature, 1.. the joints in the
    body's order."""
    rng = np.random.default_rng(seed)
    K = len(body.joint_names)
    a = body.joints() / ARMATURE_SCALE                                  # rest joint positions, armature space (cm)
    Qr = quat_to_matrix(rng.normal(size=(K, 4)))                       # rest world orientation of each joint frame
    doc = _Doc()
    armature = pygltflib.Node(name="Armature", rotation=matrix_to_quat(yaw_matrix(ARMATURE_YAW)).tolist(),
                              scale=[ARMATURE_SCALE] * 3, children=[1])
    doc.g.nodes.append(armature)
    parents = np.asarray(body.parents)
    for k, name in enumerate(body.joint_names):
        p = parents[k]
        r = Qr[k] if p < 0 else Qr[p].T @ Qr[k]
        t = a[k] if p < 0 else Qr[p].T @ (a[k] - a[p])
        doc.g.nodes.append(pygltflib.Node(name=f"mixamorig:{BODY_TO_MIXAMO[name]}", rotation=matrix_to_quat(r).tolist(),
                                          translation=t.tolist(), children=[int(c) + 1 for c in np.flatnonzero(parents == k)]))
    doc.g.skins.append(pygltflib.Skin(joints=list(range(1, K + 1))))
    doc.g.scenes.append(pygltflib.Scene(nodes=[0]))
    doc.g.scene = 0
    W, p0 = _bvh_world(clip, body)
    Wf = W @ Qr[None]                                                   # the file's world rotations: G · rest
    local = np.empty_like(Wf)
    for k, p in enumerate(parents):
        local[:, k] = Wf[:, k] if p < 0 else np.swapaxes(Wf[:, p], -1, -2) @ Wf[:, k]
    return doc, matrix_to_quat(local), p0 / ARMATURE_SCALE


def _assert_same_clip(a, b, atol=2e-4):
    assert a.local_rotations.shape == b.local_rotations.shape and a.fps == pytest.approx(b.fps)
    dots = np.abs(np.sum(a.local_rotations * b.local_rotations, axis=-1))
    assert dots.min() > 1 - atol, dots.min()
    assert np.abs(np.sum(a.root_rotation * b.root_rotation, axis=-1)).min() > 1 - atol
    assert np.abs(a.root_translation - b.root_translation).max() < atol


def test_gltf_walk_equals_the_same_walk_as_bvh(tmp_path, walk, body):
    bvh = load_clip(_mixamo_bvh(tmp_path / "walk.bvh", walk, body), body)
    doc, q, root = _walk_document(walk, body)
    T = walk.num_frames
    times = np.arange(T) / walk.fps
    still = np.tile(doc.g.nodes[1].rotation, (2, 1))
    doc.animation("idle", [(1, "rotation", [0.0, 1.0], still, "LINEAR")])
    doc.animation("walk", [(k + 1, "rotation", times, q[:, k], "LINEAR") for k in range(q.shape[1])]
                  + [(1, "translation", times, root, "LINEAR")])
    path = doc.save(tmp_path / "walk.gltf")
    clip, match = load_clip(path, body, animation="walk", with_match=True)
    assert len(match.mapping) == 24 and clip.num_frames == T and clip.fps == 30.0
    _assert_same_clip(clip, bvh)
    _assert_same_clip(load_clip(path, body, animation=1), clip, 1e-12)
    first = read_gltf(path)                             # the first animation by default: the idle one
    assert "'idle'" in first.source and first.local_rotations.shape[0] == 31
    # the same document as GLB (one binary chunk): the same clip, bit for bit
    pygltflib.GLTF2().load(str(path)).save(str(tmp_path / "walk.glb"))
    glb = load_clip(tmp_path / "walk.glb", body, animation="walk")
    assert np.array_equal(glb.local_rotations, clip.local_rotations)
    assert np.array_equal(glb.root_translation, clip.root_translation)
    assert (tmp_path / "walk.glb").read_bytes()[:4] == b"glTF"


def test_step_cubicspline_and_resampling(tmp_path, walk, body):
    doc, q, root = _walk_document(walk, body, seed=1)
    K = q.shape[1]
    keys = np.arange(0, 12, 3)                          # keys every 3rd frame: 10 per second
    times = keys / 30.0
    rng = np.random.default_rng(2)
    tangents = rng.normal(size=(len(keys), 4))
    cubic = np.stack([tangents, q[keys, 0], -tangents], axis=1).reshape(-1, 4)
    doc.animation("step", [(k + 1, "rotation", times, q[keys, k], "STEP") for k in range(K)])
    doc.animation("mixed", [(1, "rotation", times, cubic, "CUBICSPLINE")]
                  + [(k + 1, "rotation", times, q[keys, k], "LINEAR") for k in range(1, K)])
    path = doc.save(tmp_path / "keys.gltf")
    step = read_gltf(path, animation="step")
    assert step.fps == 30.0 and step.local_rotations.shape[0] == keys[-1] + 1   # 10 keys/s: resampled at 30 fps
    # STEP holds each key until the next: frames 0, 1, 2 equal
    assert np.allclose(step.local_rotations[1], step.local_rotations[0], atol=1e-7)
    assert np.allclose(step.local_rotations[2], step.local_rotations[0], atol=1e-7)
    assert not np.allclose(step.local_rotations[3], step.local_rotations[2], atol=1e-4)
    # CUBICSPLINE reads the values (tangents ignored): the same as LINEAR on the same values
    doc2, _, _ = _walk_document(walk, body, seed=1)
    doc2.animation("linear", [(k + 1, "rotation", times, q[keys, k], "LINEAR") for k in range(K)])
    linear = read_gltf(doc2.save(tmp_path / "linear.gltf"))
    mixed = read_gltf(path, animation="mixed")
    assert np.allclose(mixed.local_rotations, linear.local_rotations, atol=1e-6)
    # an explicit rate; a name that is not there lists the ones that are
    assert read_gltf(path, fps=60.0, animation="step").local_rotations.shape[0] == 2 * keys[-1] + 1
    with pytest.raises(MotionFileError, match="has no animation 'run'.*0: step, 1: mixed"):
        read_gltf(path, animation="run")


def test_broken_files_are_one_line(tmp_path, walk, body, capsys):
    from pleat.motion.cli import main
    doc, q, root = _walk_document(walk, body)
    doc.animation("walk", [(k + 1, "rotation", np.arange(4) / 30.0, q[:4, k], "LINEAR") for k in range(q.shape[1])])
    good = doc.save(tmp_path / "good.gltf")
    pygltflib.GLTF2().load(str(good)).save(str(tmp_path / "good.glb"))
    glb = (tmp_path / "good.glb").read_bytes()
    def edited(change):
        doc = json.loads(good.read_text())
        change(doc)
        return json.dumps(doc).encode()
    cases = {
        "truncated.glb": (glb[:len(glb) // 2], "truncated?"),
        "magic.glb": (b"glTX" + glb[4:], "not a GLB file"),
        "notjson.gltf": (b"{\"asset\": {\"version\": \"2.0\"", "is not JSON"),
        "version.gltf": (edited(lambda d: d["asset"].update(version="1.0")), "only glTF 2.0"),
        "noskin.gltf": (edited(lambda d: d.pop("skins")), "has no skin"),
        "accessor.gltf": (edited(lambda d: d["animations"][0]["samplers"][3].update(output=999)), "accessor index 999"),
        "short.gltf": (edited(lambda d: d["bufferViews"][5].update(byteLength=8)), "do not fit in buffer view 5"),
        "cycle.gltf": (edited(lambda d: d["nodes"][5]["children"].append(1)), "two parents"),
        "extension.gltf": (edited(lambda d: d.update(extensionsRequired=["KHR_mesh_quantization"])),
                           "KHR_mesh_quantization"),
        "binary.gltf": (b"\x00\xff" * 20, "not UTF-8"),
    }
    for name, (data, words) in cases.items():
        (tmp_path / name).write_bytes(data)
        out = tmp_path / f"{name}.npz"
        assert main(["convert", str(tmp_path / name), "--out", str(out), "--quiet"]) == 1, name
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("pleat-motion: error: ") and name in err[0], (name, err)
        assert words in err[0], (name, err[0])
        assert not out.exists()
    assert main(["convert", str(good), "--out", str(tmp_path / "ok.npz"), "--quiet"]) == 0


def test_a_floor_root_joint_with_the_root_motion_gives_the_same_walk(tmp_path, walk, body):
    """Unreal's export: a `root` joint on the floor carries the horizontal path, the hips hang from it and carry the
    rest of their motion in a translation channel of their own. Re-rooted at the hips, it is the plain walk."""
    plain_doc, q, root = _walk_document(walk, body)
    T = walk.num_frames
    times = np.arange(T) / walk.fps
    plain_doc.animation("walk", [(k + 1, "rotation", times, q[:, k], "LINEAR") for k in range(q.shape[1])]
                        + [(1, "translation", times, root, "LINEAR")])
    plain = load_clip(plain_doc.save(tmp_path / "plain.gltf"), body)

    doc, q, root = _walk_document(walk, body)
    K = len(body.joint_names)
    floor = len(doc.g.nodes)                             # the new root joint, on the floor 0.9 m below the hips
    r = np.array([0.0, -0.9 / ARMATURE_SCALE, 0.0])
    doc.g.nodes.append(pygltflib.Node(name="root", translation=r.tolist(), children=[1]))
    doc.g.nodes[0].children = [floor]
    doc.g.nodes[1].translation = (np.asarray(doc.g.nodes[1].translation) - r).tolist()
    doc.g.skins[0].joints = [floor] + list(range(1, K + 1))
    path_xz = root * np.array([1.0, 0.0, 1.0])          # the ground path on the root, the height and sway on the hips
    doc.animation("walk", [(k + 1, "rotation", times, q[:, k], "LINEAR") for k in range(q.shape[1])]
                  + [(floor, "translation", times, r + path_xz, "LINEAR"),
                     (1, "translation", times, root - path_xz - r, "LINEAR")])
    clip, match = load_clip(doc.save(tmp_path / "rooted.gltf"), body, with_match=True)
    assert match.mapping["pelvis"] == "mixamorig:Hips" and "root" not in match.mapping.values()
    _assert_same_clip(clip, plain)
